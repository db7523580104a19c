"""Trials on a Dask cluster (``--cluster tcp://HOST:8786``), each in a fresh child process on its worker.

A Dask worker is a daemonic process (it may not start ``multiprocessing``
children) and its hash seed was fixed when it started. So each task
(``in_child``) starts a fresh interpreter, ``python -m swarmactors.runs.cluster DIR``,
with ``PYTHONHASHSEED`` = ``launcher.HASH_SEED`` and the worker's import path
(modules sent with Dask's ``upload_file`` included): the trial then runs as it
runs in the local pool, with the default GC settings, the ``spawn`` start method
and, for K >= 1, its own host processes (the child is not daemonic).

The child writes into a temporary directory on the worker; the files the caller
keeps (a failed trial's result.json and trace) come back as a tar archive, so
workers need no shared filesystem. The child dies with its worker (it watches
its parent) and when the sweep is cancelled (a Dask ``Event`` polled by the
task), taking its host processes with it (its own process group).

Faults: a worker that dies mid-task is Dask's to handle (the scheduler
reschedules the task, up to ``distributed.scheduler.allowed-failures`` times,
then ``KilledWorker``); a task whose trial raises returns the error as data, so
it is recorded once and never retried; a scheduler that goes away ends the run
with ``ClusterError``.
"""

from __future__ import annotations

import importlib
import io
import logging
import os
import pickle
import signal
import subprocess
import sys
import tarfile
import tempfile
import threading
import time
import uuid
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

CONNECT_TIMEOUT_S = 10.0  # an unreachable scheduler is reported after this long
POLL_S = 0.5  # how often a task looks at its child and at the cancel event
LOST_S = 15.0  # a client that has not been connected for this long: the scheduler is gone
# Packages that must have the same version on the client, the scheduler and every worker: they carry the tasks
# and their results (Dask's protocol and pickling). Python must agree on major.minor (pickled code); its patch
# level and Dask's optional packages (numpy, pandas, lz4, ...) may differ, as between a client's virtual
# environment and the Debian-based image.
SAME_VERSION = ("dask", "distributed", "msgpack", "cloudpickle", "tornado", "toolz")


class ClusterError(RuntimeError):
    """The cluster could not do the work: scheduler unreachable or gone (exit 3)."""


class WorkerSetupError(ValueError):
    """A worker lacks a module the trials use (exit 2: install it there or upload it)."""


# ---------------------------------------------------------------- client side
def scheduler_address(text: str) -> str:
    """``tcp://HOST:PORT`` (``HOST:PORT`` gets ``tcp://``); ``ValueError`` naming the option if malformed."""
    address = text if "://" in text else f"tcp://{text}"
    scheme, _, rest = address.partition("://")
    host, _, port = rest.rpartition(":")
    if scheme not in ("tcp", "tls") or not host or not port.isdigit():
        raise ValueError(f"--cluster {text!r}: expected tcp://HOST:PORT or tls://HOST:PORT (a Dask scheduler, e.g. "
                         "tcp://10.0.0.5:8786)")
    return address


def tls_security(address: str, certs: str | Path | None = None):
    """Dask's ``Security`` for a ``tls://`` scheduler: the CA and ``cluster.pem``/``.key`` of ``certs``.

    ``certs`` defaults to ``$SWARMACTORS_CLUSTER_CERTS`` (what ``--cluster-certs DIR`` sets); None for ``tcp://``.
    ``ValueError`` (exit 2) naming what is missing.
    """
    if not address.startswith("tls://"):
        return None
    from distributed.security import Security

    folder = certs or os.environ.get("SWARMACTORS_CLUSTER_CERTS")
    if not folder:
        raise ValueError(f"--cluster {address}: a tls:// scheduler needs --cluster-certs DIR (the directory with "
                         "ca.pem, cluster.pem and cluster.key: docs/scaling.md)")
    folder = Path(folder)
    for name in ("ca.pem", "cluster.pem", "cluster.key"):
        if not (folder / name).is_file():
            raise ValueError(f"--cluster-certs {folder}: no {name} there (swarmactors cluster-certs {folder} "
                             "creates them)")
    return Security(tls_ca_file=str(folder / "ca.pem"), tls_client_cert=str(folder / "cluster.pem"),
                    tls_client_key=str(folder / "cluster.key"), require_encryption=True)


def connect(text: str, timeout: float | None = None, certs: str | Path | None = None):
    """A ``distributed.Client`` of the scheduler at ``text``; ``ClusterError`` naming the address if unreachable.

    ``timeout`` defaults to ``$SWARMACTORS_CLUSTER_TIMEOUT`` seconds, else ``CONNECT_TIMEOUT_S``; a ``tls://``
    address uses the certificates of ``certs`` (``tls_security``).
    """
    from distributed import Client

    address = scheduler_address(text)
    security = tls_security(address, certs)
    if timeout is None:
        try:
            timeout = float(os.environ.get("SWARMACTORS_CLUSTER_TIMEOUT", CONNECT_TIMEOUT_S))
        except ValueError:
            raise ValueError(f"SWARMACTORS_CLUSTER_TIMEOUT={os.environ['SWARMACTORS_CLUSTER_TIMEOUT']!r}: "
                             "expected seconds") from None
    from distributed.versions import VersionMismatchWarning

    try:
        with warnings.catch_warnings():  # Dask warns on any difference; version_mismatches judges those that matter
            warnings.simplefilter("ignore", VersionMismatchWarning)
            client = Client(address, timeout=timeout, set_as_default=False, security=security)
    except (OSError, TimeoutError) as exc:
        raise ClusterError(f"cannot reach the Dask scheduler at {address} within {timeout:g} s ({exc})") from None
    if not client.scheduler_info().get("workers"):
        try:
            client.wait_for_workers(1, timeout=timeout)
        except (OSError, TimeoutError):
            client.close()
            raise ClusterError(f"the Dask scheduler at {address} has no workers (none joined in {timeout:g} s)"
                               ) from None
    versions = client.get_versions()
    peers = {"scheduler": versions["scheduler"]["packages"]}
    peers.update({f"worker {w}": v["packages"] for w, v in sorted(versions["workers"].items())})
    problems = version_mismatches(versions["client"]["packages"], peers)
    if problems:
        client.close()
        raise ClusterError(f"the Dask cluster at {address} does not match this client: {'; '.join(problems)} "
                           "(install the same versions there, e.g. from constraints.txt)")
    return client


def version_mismatches(mine: dict[str, str | None], peers: dict[str, dict[str, str | None]]) -> list[str]:
    """What differs from this client's ``mine`` ({package: version}) in ``peers`` ({name: packages}) and matters.

    Python must agree on major.minor, the packages of ``SAME_VERSION`` exactly; anything else may differ.
    """
    def python(version: str | None) -> str | None:
        return ".".join(version.split(".")[:2]) if version else version

    problems = []
    for name, theirs in peers.items():
        if python(theirs.get("python")) != python(mine.get("python")):
            problems.append(f"{name} runs Python {theirs.get('python')}, this client {mine.get('python')}")
        for package in SAME_VERSION:
            if theirs.get(package) != mine.get(package):
                problems.append(f"{name} has {package} {theirs.get(package)}, this client {mine.get(package)}")
    return problems


def _importable(modules: list[str]) -> dict:
    """On a worker: {module: error} for the modules it cannot import (with the trials' import path)."""
    missing = {}
    for name in modules:
        try:
            importlib.import_module(name)
        except Exception as exc:  # ImportError, or the module raised while importing
            missing[name] = f"{exc.__class__.__name__}: {exc}"
    return missing


def require_modules(client, modules: Iterable[str]) -> None:
    """Every worker can import ``modules``; ``WorkerSetupError`` naming the module and the worker otherwise."""
    modules = sorted(set(modules))
    if not modules:
        return
    answers = client.run(_importable, modules)
    for worker, missing in sorted(answers.items()):
        for name, error in sorted(missing.items()):
            raise WorkerSetupError(
                f"module {name!r} cannot be imported on Dask worker {worker} ({error}): install it on every worker "
                f"(pip install ...) or send it with Dask's upload_file (see docs/scaling.md)")


def user_modules(uses: Iterable[str]) -> set[str]:
    """The modules of ``module:Class`` references (registered short names need nothing)."""
    return {u.partition(":")[0] for u in uses if isinstance(u, str) and ":" in u}


@dataclass
class Job:
    """One task: ``func`` ("module:function") called as ``func(*args, out=DIR)`` in a child on a worker."""

    key: object  # the caller's key for the result
    func: str
    args: tuple
    name: str = "task"


@dataclass
class Reply:
    """What a task gave back: the function's value, or an error text; ``files`` a tar of its kept files."""

    value: object = None
    error: str | None = None
    files: bytes | None = None
    keep: bool = False  # in the child: the caller wants the files
    tmp: str = ""  # the child's output directory on the worker (to rewrite paths that name it)
    worker: str = ""


def run_jobs(client, jobs: list[Job], on_reply: Callable[[Job, Reply], None],
             on_status: Callable[[int], None] | None = None) -> bool:
    """Submit ``jobs``, hand each reply to ``on_reply`` as it comes; return True if interrupted by Ctrl-C.

    ``on_status(running)`` is called about once a second with the number of tasks being processed.
    ``ClusterError`` when the scheduler goes away (replies already handed over stay handed over).
    """
    from distributed import Event, as_completed
    from distributed.scheduler import KilledWorker

    if not jobs:
        return False
    cancel = f"swarmactors-cancel-{uuid.uuid4().hex}"
    event = Event(cancel, client=client)
    tag = uuid.uuid4().hex[:8]
    futures = {}
    for i, job in enumerate(jobs):
        fut = client.submit(in_child, job.func, job.args, cancel, key=f"swarmactors-{job.name}-{tag}-{i}",
                            pure=False)
        futures[fut] = job
    pending = as_completed(list(futures), loop=client.loop)
    last_status, lost_since = 0.0, None
    try:
        while not pending.is_empty():
            if not pending.has_ready():
                now = time.monotonic()
                if client.status != "running":
                    lost_since = lost_since or now
                    if now - lost_since > LOST_S:
                        raise ClusterError(f"lost the Dask scheduler at {client.scheduler.address}")
                else:
                    lost_since = None
                if on_status and now - last_status > 1.0:
                    last_status = now
                    on_status(_running(client, futures))
                time.sleep(0.1)
                continue
            for fut in pending.next_batch(block=False):
                job = futures[fut]
                if fut.status == "finished":
                    reply = fut.result()
                elif fut.status == "cancelled":  # the scheduler forgot it: it went away
                    raise ClusterError(f"lost the Dask scheduler at {client.scheduler.address}")
                else:
                    exc = fut.exception()
                    if isinstance(exc, KilledWorker):
                        text = f"KilledWorker: the workers running it died too often (Dask's allowed-failures): {exc}"
                    else:
                        text = f"{exc.__class__.__name__}: {exc}"
                    reply = Reply(error=text)
                if reply.error is None or not reply.error.startswith("cancelled"):
                    on_reply(job, reply)
                fut.release()
    except KeyboardInterrupt:
        _stop(client, event, futures)
        return True
    except BaseException:  # the scheduler is gone, or on_reply gave up
        _stop(client, event, futures)
        raise
    return False


def _running(client, futures) -> int:
    """Tasks of ours that workers are running: per worker, at most as many as it has threads."""
    try:
        processing, threads = client.processing(), client.nthreads()
    except Exception:  # the scheduler is busy or away: no number this time
        return 0
    ours = {f.key for f in futures}
    return sum(min(sum(k in ours for k in keys), threads.get(w, 1)) for w, keys in processing.items())


def _stop(client, event, futures) -> None:
    """Tell running tasks to kill their children, drop the queued ones."""
    try:
        event.set()
        client.cancel(list(futures))
    except Exception as exc:  # the scheduler is away: its workers stop the tasks when they lose it
        logging.getLogger(__name__).debug("cancel: %s", exc)


def extract(files: bytes, dest: Path) -> None:
    """Unpack a task's kept files into ``dest`` (replacing what was there)."""
    import shutil

    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    with tarfile.open(fileobj=io.BytesIO(files)) as tar:
        if hasattr(tarfile, "data_filter"):  # Python >= 3.11.4: refuse links and paths out of dest
            tar.extractall(dest, filter="data")
        else:
            for member in tar.getmembers():
                if not (member.isfile() or member.isdir()) or member.name.startswith(("/", "..")) \
                        or "/../" in member.name:
                    raise ClusterError(f"a task sent back an unsafe file {member.name!r}")
            tar.extractall(dest)


# ---------------------------------------------------------------- worker side
def in_child(func: str, args: tuple, cancel: str | None = None) -> Reply:
    """A Dask task: run ``func(*args, out=DIR)`` in a fresh child interpreter on this worker."""
    from distributed import Event, get_worker

    from swarmactors.runs.launcher import HASH_SEED

    worker = get_worker().address
    with tempfile.TemporaryDirectory(prefix="swarmactors-task-") as tmp:
        folder = Path(tmp)
        (folder / "task.pickle").write_bytes(pickle.dumps((func, args)))
        env = {**os.environ, "PYTHONHASHSEED": HASH_SEED,
               "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
        with open(folder / "stderr.txt", "wb") as errf:
            proc = subprocess.Popen([sys.executable, "-m", "swarmactors.runs.cluster", str(folder)], env=env,
                                    stdin=subprocess.DEVNULL, stdout=errf, stderr=errf, start_new_session=True)
        event = Event(cancel) if cancel else None
        try:
            while True:
                try:
                    code = proc.wait(timeout=POLL_S)
                    break
                except subprocess.TimeoutExpired:
                    if event is not None and _cancelled(event):
                        _kill_group(proc)
                        return Reply(error="cancelled", worker=worker)
        except BaseException:
            _kill_group(proc)
            raise
        reply_path = folder / "reply.pickle"
        if not reply_path.exists():
            tail = (folder / "stderr.txt").read_text(errors="replace").strip().splitlines()[-3:]
            return Reply(error=f"the trial's process on Dask worker {worker} exited with code {code}"
                               + (f": {' / '.join(tail)}" if tail else ""), worker=worker)
        reply: Reply = pickle.loads(reply_path.read_bytes())
        reply.worker = worker
        out = folder / "out"
        if reply.keep and out.is_dir():
            buf = io.BytesIO()
            with tarfile.open(fileobj=buf, mode="w:gz") as tar:
                for p in sorted(out.iterdir()):
                    tar.add(p, arcname=p.name)
            reply.files = buf.getvalue()
        else:
            reply.files = None
        return reply


def _cancelled(event) -> bool:
    try:
        return event.is_set()
    except Exception:  # the scheduler is gone: nobody wants this result any more
        return True


def _kill_group(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


def _watch_parent(parent: int) -> None:
    """In the child: when the worker dies (we are re-parented), kill this process group (hosts included)."""
    while os.getppid() == parent:
        time.sleep(POLL_S)
    os.killpg(os.getpgrp(), signal.SIGKILL)


def _child(folder: Path) -> None:
    """``python -m swarmactors.runs.cluster DIR``: run DIR/task.pickle, write DIR/reply.pickle."""
    logging.basicConfig(level=logging.ERROR)
    threading.Thread(target=_watch_parent, args=(os.getppid(),), daemon=True).start()
    func, args = pickle.loads((folder / "task.pickle").read_bytes())
    module, _, name = func.partition(":")
    out = folder / "out"
    reply = Reply(tmp=str(out))
    try:
        value, keep = getattr(importlib.import_module(module), name)(*args, out=out)
        reply.value, reply.keep = value, bool(keep)
    except Exception as exc:  # recorded as the task's result: a deterministic failure is not retried
        reply.error = f"{exc.__class__.__name__}: {exc}"
    (folder / "reply.pickle").write_bytes(pickle.dumps(reply))


if __name__ == "__main__":
    from swarmactors.runs.cluster import _child as child  # the module's Reply, not __main__'s, goes into the pickle

    child(Path(sys.argv[1]))

"""Sweeps and conformance suites on a Dask cluster: a real LocalCluster with 2 worker processes (issue 24)."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import pytest

from swarmactors.cli import main

SCENARIO = """
[run]
name = "cl"
seed = 9
ticks = 12

[[robots]]
count = 5
placement = "line"
spacing = 0.9
behaviors = [{ use = "flooding", origin = 0, at = 1, expiry = 6 }]

[[checks]]
use = "flooding.delivered"
"""
# a 2 x 3 grid of 2 trials, half of them with K = 2 host processes
GRID = ["--grid", "run.processes=0,2", "--grid", "radio.loss=0,0.1,0.3", "--trials", "2"]


def _rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def cluster():
    """A LocalCluster of 2 single-threaded worker processes (with nannies: a killed worker is restarted)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        with distributed.Client(c) as client:
            yield c.scheduler_address, client


@pytest.fixture(scope="module")
def scenario(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("scenario") / "cl.toml"
    path.write_text(SCENARIO)
    return path


@pytest.fixture(scope="module")
def local_csv(scenario, tmp_path_factory) -> bytes:
    """The sweep's trials.csv from the local process pool."""
    out = tmp_path_factory.mktemp("local") / "sweep"
    assert main(["sweep", str(scenario), *GRID, "--workers", "2", "--out", str(out), "--quiet"]) == 0
    return (out / "trials.csv").read_bytes()


@pytest.mark.slow
def test_cluster_sweep_cut_by_ctrl_c_then_resumed_is_byte_identical_to_the_local_pool(cluster, scenario, local_csv,
                                                                                      tmp_path):
    """One test for both promises (a cluster run takes time): rows as the local pool's, and a clean resumption."""
    address, _ = cluster
    out = tmp_path / "cut"
    cmd = [sys.executable, "-m", "swarmactors", "sweep", str(scenario), *GRID, "--cluster", address,
           "--out", str(out), "--json"]
    cut = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not (out / "trials.csv").exists() or len(_rows(out / "trials.csv")) < 2:
        assert time.monotonic() < deadline and cut.poll() is None, cut.communicate()
        time.sleep(0.05)
    cut.send_signal(signal.SIGINT)
    _, err = cut.communicate(timeout=60)
    assert cut.returncode == 130, err
    done = _rows(out / "trials.csv")
    assert 2 <= len(done) < 12
    assert len({(r["run.processes"], r["radio.loss"], r["trial"]) for r in done}) == len(done)
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=240)
    assert again.returncode == 0, again.stderr
    summary = json.loads(again.stdout)
    assert summary["skipped"] == len(done) and summary["ran"] == 12 - len(done)
    assert (out / "trials.csv").read_bytes() == local_csv
    rows = _rows(out / "trials.csv")
    assert {r["passed"] for r in rows} == {"true"} and not any(r["error"] for r in rows)
    # K = 0 and K = 2 give the same run: the same trace hash at every (loss, trial)
    by_k = {k: [(r["radio.loss"], r["trial"], r["trace_hash"]) for r in rows if r["run.processes"] == k]
            for k in ("0", "2")}
    assert by_k["0"] == by_k["2"] and len(by_k["0"]) == 6


@pytest.mark.slow
def test_a_worker_killed_mid_trial_is_rescheduled_and_each_row_appears_once(cluster, scenario, tmp_path):
    address, client = cluster
    out = tmp_path / "killed"
    slow = scenario.parent / "cl-slow.toml"
    slow.write_text(SCENARIO.replace("ticks = 12", "ticks = 200"))
    cmd = [sys.executable, "-m", "swarmactors", "sweep", str(slow), "--grid", "radio.loss=0,0.2", "--trials", "1",
           "--cluster", address, "--out", str(out), "--json"]
    sweep = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    pids = client.run(os.getpid)
    victim, deadline = None, time.monotonic() + 120
    while victim is None:
        assert time.monotonic() < deadline and sweep.poll() is None, sweep.communicate()
        for worker, keys in client.processing().items():
            if any(str(k).startswith("swarmactors-trial-") for k in keys) and worker in pids:
                victim = pids[worker]
        time.sleep(0.1)
    time.sleep(1.5)  # the trial's child process is starting or running
    os.kill(victim, signal.SIGKILL)
    out_text, err = sweep.communicate(timeout=240)
    assert sweep.returncode == 0, err
    assert json.loads(out_text)["ran"] == 2
    rows = _rows(out / "trials.csv")
    assert sorted((r["radio.loss"], r["trial"]) for r in rows) == [("0", "0"), ("0.2", "0")]
    assert {r["passed"] for r in rows} == {"true"} and not any(r["error"] for r in rows)
    client.wait_for_workers(2, timeout=60)  # the nanny restarted the killed worker, for the tests after this one


@pytest.mark.slow
def test_check_flooding_quick_on_the_cluster(cluster, tmp_path):
    from swarmactors.runs.conformance import select
    from test_pins import CASE_PINS

    address, _ = cluster
    report = tmp_path / "check.json"
    assert main(["check", "flooding", "--quick", "--cluster", address, "--out", str(tmp_path / "runs"),
                 "--json", str(report)]) == 0
    results = json.loads(report.read_text())
    assert [r["case"] for r in results] == [c.name for _, c in select("flooding", "quick")]
    assert all(r["passed"] for r in results)
    lockstep = [r for r in results if r["case"] in CASE_PINS]
    assert len(lockstep) >= 5
    for r in lockstep:  # the same runs as locally: the pinned trace hashes, and K = 2 agreed
        assert [o["passed"] for o in r["outcomes"] if o["name"] == "determinism"] == [True]
        assert r["trace_hash"] == CASE_PINS[r["case"]], r["case"]


@pytest.mark.slow
def test_a_behaviour_module_missing_on_the_workers_names_module_and_worker(cluster, tmp_path, capsys, monkeypatch):
    address, client = cluster
    (tmp_path / "only_here_beh.py").write_text(
        "from protocols.flooding.behavior import Flooding\n\nclass Mine(Flooding):\n    pass\n")
    scenario = tmp_path / "mine.toml"
    scenario.write_text(SCENARIO)
    monkeypatch.chdir(tmp_path)  # importable here (beside the scenario), not on the workers
    code = main(["sweep", str(scenario), "--set", 'robots.0.behaviors.0.use="only_here_beh:Mine"',
                 "--cluster", address, "--out", str(tmp_path / "s"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2, err
    workers = sorted(client.scheduler_info()["workers"])
    assert "'only_here_beh'" in err and any(w in err for w in workers), err
    assert not (tmp_path / "s" / "trials.csv").exists()
    client.upload_file(str(tmp_path / "only_here_beh.py"))  # the other way: Dask ships the module to the workers
    assert main(["sweep", str(scenario), "--set", 'robots.0.behaviors.0.use="only_here_beh:Mine"',
                 "--cluster", address, "--out", str(tmp_path / "s"), "--quiet"]) == 0
    (row,) = _rows(tmp_path / "s" / "trials.csv")
    assert row["passed"] == "true" and not row["error"]


def test_an_unreachable_scheduler_exits_3_naming_it(tmp_path, capsys, monkeypatch):
    pytest.importorskip("distributed")
    scenario = tmp_path / "cl.toml"
    scenario.write_text(SCENARIO)
    monkeypatch.setenv("SWARMACTORS_CLUSTER_TIMEOUT", "1")
    code = main(["sweep", str(scenario), "--cluster", "tcp://127.0.0.1:9", "--out", str(tmp_path / "s"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 3, err
    assert "tcp://127.0.0.1:9" in err and "Dask scheduler" in err
    assert not (tmp_path / "s").exists()
    assert main(["check", "flooding", "--cluster", "tcp://127.0.0.1:9", "--out", str(tmp_path / "c")]) == 3
    assert "tcp://127.0.0.1:9" in capsys.readouterr().err
    assert main(["sweep", str(scenario), "--cluster", "no-port", "--quiet"]) == 2
    assert "--cluster 'no-port'" in capsys.readouterr().err


def test_a_sweep_file_with_an_unknown_key_exits_2_naming_file_and_key(tmp_path, capsys):
    (tmp_path / "cl.toml").write_text(SCENARIO)
    spec = tmp_path / "exp.toml"
    spec.write_text('[sweep]\nscenario = "cl.toml"\ntrials = 2\ngrid = { "radio.loss" = [0, 0.1] }\nworkers = 3\n')
    assert main(["sweep", str(spec), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert str(spec) in err and "'sweep.workers'" in err
    spec.write_text('[sweep]\nscenario = "cl.toml"\n[extra]\n')
    assert main(["sweep", str(spec), "--quiet"]) == 2
    assert "'extra'" in capsys.readouterr().err
    spec.write_text('[sweep]\nscenario = "cl.toml"\ntrials = 0\n')
    assert main(["sweep", str(spec), "--quiet"]) == 2
    assert "'sweep.trials'" in capsys.readouterr().err


def test_a_sweep_file_is_the_sweep_of_its_options(tmp_path):
    from swarmactors.tools.sweep import plan

    (tmp_path / "cl.toml").write_text(SCENARIO)
    spec = tmp_path / "exp.toml"
    spec.write_text('[sweep]\nscenario = "cl.toml"\nset = ["radio.loss=0.1"]\ntrials = 3\n'
                    'grid = { "robots.0.count" = [4, 6] }\nout = "o"\n')
    a = plan(spec, [], [], None, None)
    b = plan(tmp_path / "cl.toml", ["radio.loss=0.1"], ["robots.0.count=4,6"], 3, Path("o"))
    assert (a.identity["overrides"], a.grid, a.trials, a.out) == (b.identity["overrides"], b.grid, b.trials, b.out)
    assert a.all_trials() == b.all_trials() and a.identity == b.identity
    assert plan(spec, [], ["radio.range=1,2"], 1, None).keys == ["robots.0.count", "radio.range"]
    assert plan(spec, [], ["robots.0.count=5"], 1, None).grid == [("robots.0.count", [5])]  # replaces the file's


@pytest.mark.docker
@pytest.mark.slow
def test_compose_cluster_profile_runs_a_sweep_submitted_from_the_host(image, scenario, tmp_path, capsys,
                                                                       monkeypatch):
    """docker/compose.yaml --profile cluster: a scheduler and 2 workers over mutual TLS; the same CSV as locally.

    A client without the cluster's certificate, or with another CA's, is refused (exit 3). The image is
    tests/conftest.py's, built once per session for tests/test_docker.py too.
    """
    import socket
    import uuid

    compose = image
    repo = Path(__file__).resolve().parents[1]
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    certs = tmp_path / "certs"
    certs.mkdir()
    certs.chmod(0o777)  # the containers' user (1000) writes the certificates there
    env = {**os.environ, "DASK_PORT": str(port), "CLUSTER_CERTS": str(certs)}
    base = [*compose, "-p", f"sc{uuid.uuid4().hex[:8]}", "-f", str(repo / "docker" / "compose.yaml"),
            "--profile", "cluster"]
    grid = ["--grid", "run.processes=0,2", "--grid", "radio.loss=0,0.3", "--trials", "1"]
    address = f"tls://127.0.0.1:{port}"
    try:
        up = subprocess.run([*base, "up", "-d", "--scale", "worker=2", "scheduler", "worker"], env=env,
                            capture_output=True, text=True, timeout=300)
        assert up.returncode == 0, up.stderr
        from distributed import Client
        from distributed.versions import VersionMismatchWarning

        from swarmactors.runs.cluster import tls_security

        deadline = time.monotonic() + 120
        while True:  # the published port answers before the scheduler inside does
            try:
                with warnings.catch_warnings():  # the image's Python is 3.11.2: connect() judges versions
                    warnings.simplefilter("ignore", VersionMismatchWarning)
                    with Client(address, timeout=10, security=tls_security(address, certs)) as client:
                        client.wait_for_workers(2, timeout=120)
                break
            # ValueError: the certificates are not written yet. AssertionError: distributed's client starts its
            # IO-loop thread with a fixed 10 s wait and asserts it started; on 2 cores busy starting the
            # containers it once did not (CI), before any contact with the scheduler: try again, like a refusal.
            except (OSError, ValueError, AssertionError):
                assert time.monotonic() < deadline, "the compose scheduler never answered"
                time.sleep(1)
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            assert main(["sweep", str(scenario), *grid, "--cluster", address, "--cluster-certs", str(certs),
                         "--out", str(tmp_path / "compose"), "--quiet"]) == 0
        # the client's venv and the image differ only where it does not matter (Python's patch level, pandas)
        assert not [w for w in seen if issubclass(w.category, VersionMismatchWarning)]
        monkeypatch.setenv("SWARMACTORS_CLUSTER_TIMEOUT", "3")
        capsys.readouterr()
        assert main(["sweep", str(scenario), "--cluster", f"tcp://127.0.0.1:{port}", "--out",
                     str(tmp_path / "plain"), "--quiet"]) == 3  # plain TCP: the TLS handshake fails
        from transport.security import cluster_files

        other = cluster_files(tmp_path / "other")  # certificates of another CA
        assert main(["sweep", str(scenario), "--cluster", address, "--cluster-certs", str(other), "--out",
                     str(tmp_path / "other-ca"), "--quiet"]) == 3
        assert "cannot reach the Dask scheduler" in capsys.readouterr().err
    finally:
        subprocess.run([*base, "down", "--remove-orphans", "-t", "2"], env=env, capture_output=True, timeout=120)
    assert main(["sweep", str(scenario), *grid, "--workers", "2", "--out", str(tmp_path / "local"), "--quiet"]) == 0
    assert len(_rows(tmp_path / "compose" / "trials.csv")) == 4
    assert (tmp_path / "compose" / "trials.csv").read_bytes() == (tmp_path / "local" / "trials.csv").read_bytes()


@pytest.mark.slow
def test_a_failing_or_crashing_task_is_recorded_once_and_not_retried(cluster, tmp_path):
    from swarmactors.runs.cluster import Job, run_jobs

    address, client = cluster
    log = tmp_path / "ran.txt"
    module = tmp_path / "failing_tasks.py"
    module.write_text(textwrap.dedent("""
        import os

        def fail(log, *, out):
            with open(log, "a") as f:
                f.write("fail\\n")
            raise ValueError("always")

        def crash(log, *, out):
            with open(log, "a") as f:
                f.write("crash\\n")
            os._exit(7)
    """))
    client.upload_file(str(module))
    replies = []
    jobs = [Job("f", "failing_tasks:fail", (str(log),)), Job("c", "failing_tasks:crash", (str(log),))]
    assert run_jobs(client, jobs, lambda job, reply: replies.append((job.key, reply))) is False
    got = dict(replies)
    assert len(replies) == 2 and got["f"].error == "ValueError: always"
    assert "exited with code 7" in got["c"].error and got["c"].worker in got["c"].error
    assert sorted(log.read_text().split()) == ["crash", "fail"]  # each ran once: no retry


@pytest.mark.slow
def test_a_sweep_file_runs_its_post_function_on_the_csv(tmp_path, monkeypatch):
    (tmp_path / "cl.toml").write_text(SCENARIO)
    (tmp_path / "exp_figure.py").write_text(textwrap.dedent("""
        import csv

        def draw(trials_csv, out):
            rows = list(csv.DictReader(open(trials_csv)))
            path = out / "figure.txt"
            path.write_text(" ".join(sorted(r["radio.loss"] for r in rows)))
            return [path]
    """))
    spec = tmp_path / "exp.toml"
    spec.write_text('[sweep]\nscenario = "cl.toml"\ngrid = { "radio.loss" = [0, 0.2] }\nout = "o"\n'
                    'post = "exp_figure:draw"\n')
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", str(spec), "--workers", "1", "--quiet"]) == 0
    assert (tmp_path / "o" / "figure.txt").read_text() == "0 0.2"
    spec.write_text(spec.read_text().replace("exp_figure:draw", "exp_figure:nothing"))
    assert main(["sweep", str(spec), "--quiet"]) == 2


CALLABLE_MODULE = textwrap.dedent("""
    import random

    def trial(params, *, seed, trial):
        if params["n"] == 3 and trial == 1:
            raise ValueError("no instance 3/1")
        rng = random.Random(seed * 1000 + params["n"])
        draws = [rng.random() for _ in range(params["n"] * params["scale"])]
        return {"n": params["n"], "mean": sum(draws) / len(draws), "stats": {"max": max(draws), "trial": trial}}
""")


def _callable_spec(tmp_path: Path) -> Path:
    (tmp_path / "draws_trial.py").write_text(CALLABLE_MODULE)
    spec = tmp_path / "draws.toml"
    spec.write_text('[sweep]\ntrial = "draws_trial:trial"\nparams = { scale = 10 }\nseed = 4\n'
                    'grid = { n = [1, 2, 3] }\ntrials = 2\n')
    return spec


@pytest.mark.slow
def test_a_sweep_of_a_trial_function_gives_the_same_rows_locally_and_on_the_cluster(cluster, tmp_path, monkeypatch):
    """Trials that are not runs (one MILP instance, say): a callable named in the sweep file.

    As in the Table II sweep (protocols/tsc/experiments/tsc-table2.toml).
    """
    address, client = cluster
    spec = _callable_spec(tmp_path)
    monkeypatch.chdir(tmp_path)
    # one trial raises: its row keeps the error and the sweep exits 1 (a trial could not run), locally and on Dask
    assert main(["sweep", str(spec), "--workers", "2", "--out", "local", "--quiet"]) == 1
    rows = _rows(tmp_path / "local" / "trials.csv")
    assert [(r["n"], r["trial"]) for r in rows] == [(n, t) for n in "123" for t in "01"]
    assert list(rows[0])[:5] == ["n", "trial", "seed", "error", "metric.mean"]
    bad = [r for r in rows if r["error"]]
    assert [(r["n"], r["trial"], r["error"]) for r in bad] == [("3", "1", "ValueError: no instance 3/1")]
    good = [r for r in rows if not r["error"]]
    assert all(0 < float(r["metric.mean"]) < 1 and r["metric.stats.trial"] == r["trial"] for r in good)
    assert len({r["seed"] for r in rows}) == 2  # trial i of every point has the same seed
    client.upload_file(str(tmp_path / "draws_trial.py"))
    assert main(["sweep", str(spec), "--cluster", address, "--out", "dask", "--quiet"]) == 1
    assert (tmp_path / "dask" / "trials.csv").read_bytes() == (tmp_path / "local" / "trials.csv").read_bytes()


def test_a_sweep_of_a_trial_function_is_checked_before_it_starts(tmp_path, capsys, monkeypatch):
    spec = _callable_spec(tmp_path)
    monkeypatch.chdir(tmp_path)
    text = spec.read_text()
    for body, words in [
        (text + 'scenario = "x.toml"\n', ["'sweep.scenario'", "either a scenario or a trial function"]),
        (text.replace("draws_trial:trial", "draws_trial:missing"), ["'sweep.trial'", "cannot load it"]),
        (text.replace("seed = 4", 'seed = "four"'), ["'sweep.seed'", "an integer"]),
        ('[sweep]\nscenario = "x.toml"\nparams = { a = 1 }\n', ["'sweep.params'", "trial function"]),
    ]:
        spec.write_text(body)
        assert main(["sweep", str(spec), "--quiet", "--out", "o"]) == 2
        err = capsys.readouterr().err
        assert str(spec) in err and all(w in err for w in words), err
    spec.write_text(text)
    assert main(["sweep", str(spec), "--quiet", "--clock", "realtime", "--out", "o"]) == 2
    assert "has no scenario" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_cluster_certificates_and_what_a_tls_address_needs(tmp_path, capsys, monkeypatch):
    from cryptography import x509

    from swarmactors.runs.cluster import tls_security

    assert main(["cluster-certs", str(tmp_path / "c"), "--name", "dask.example"]) == 0
    folder = tmp_path / "c"
    ca = x509.load_pem_x509_certificate((folder / "ca.pem").read_bytes())
    cert = x509.load_pem_x509_certificate((folder / "cluster.pem").read_bytes())
    cert.verify_directly_issued_by(ca)  # signed by the run's CA (raises otherwise)
    names = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert {"scheduler", "localhost", "dask.example"} <= set(names.get_values_for_type(x509.DNSName))
    assert (folder / "cluster.key").stat().st_mode & 0o777 == 0o600
    before = (folder / "cluster.pem").read_bytes()
    assert main(["cluster-certs", str(folder)]) == 0 and (folder / "cluster.pem").read_bytes() == before  # kept
    assert tls_security("tcp://h:1", folder) is None
    sec = tls_security("tls://h:1", folder)
    assert sec.require_encryption and sec.tls_client_cert == str(folder / "cluster.pem")
    monkeypatch.delenv("SWARMACTORS_CLUSTER_CERTS", raising=False)
    (tmp_path / "s.toml").write_text(SCENARIO)
    capsys.readouterr()
    assert main(["sweep", str(tmp_path / "s.toml"), "--cluster", "tls://127.0.0.1:9", "--quiet"]) == 2
    assert "needs --cluster-certs DIR" in capsys.readouterr().err
    (folder / "cluster.key").unlink()
    assert main(["check", "flooding", "--cluster", "tls://127.0.0.1:9", "--cluster-certs", str(folder)]) == 2
    assert f"--cluster-certs {folder}: no cluster.key there" in capsys.readouterr().err


@pytest.mark.slow
def test_the_scheduler_going_away_mid_sweep_exits_3_with_a_resumable_csv(tmp_path):
    """A scheduler killed while trials run: exit 3 naming it; the rows so far stay, and the sweep resumes."""
    pytest.importorskip("distributed")
    # The scheduler picks its own port and writes it to a file: a port chosen here and freed before the scheduler
    # binds it can be taken in between (CI once waited 60 s for a scheduler that had never started).
    dask = Path(sys.executable).with_name("dask")
    address_file = tmp_path / "scheduler.json"
    log = tmp_path / "scheduler.log"
    with log.open("w") as log_file:
        scheduler = subprocess.Popen([str(dask), "scheduler", "--port", "0", "--no-dashboard", "--scheduler-file",
                                      str(address_file)], stdout=subprocess.DEVNULL, stderr=log_file)
    started = time.monotonic() + 120
    address = None
    while address is None:
        assert scheduler.poll() is None, log.read_text()
        assert time.monotonic() < started, "the Dask scheduler did not start in 120 s:\n" + log.read_text()
        try:
            address = json.loads(address_file.read_text())["address"]
        except (OSError, ValueError, KeyError):  # not written yet, or half written
            time.sleep(0.1)
    worker = subprocess.Popen([str(dask), "worker", address, "--nthreads", "1", "--no-dashboard"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    scenario = tmp_path / "cl.toml"
    scenario.write_text(SCENARIO)  # one worker thread: each trial's child takes seconds to start, rows come slowly
    out = tmp_path / "s"
    grid = ["--grid", "radio.loss=0,0.1,0.2", "--trials", "2"]
    try:
        sweep = subprocess.Popen([sys.executable, "-m", "swarmactors", "sweep", str(scenario), *grid, "--cluster",
                                  address, "--out", str(out), "--quiet"], stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True,
                                 env={**os.environ, "SWARMACTORS_CLUSTER_TIMEOUT": "60"})
        deadline = time.monotonic() + 120
        while not (out / "trials.csv").exists() or not _rows(out / "trials.csv"):
            assert time.monotonic() < deadline and sweep.poll() is None, sweep.communicate()
            time.sleep(0.1)
        scheduler.kill()
        _, err = sweep.communicate(timeout=120)
    finally:
        for p in (scheduler, worker):
            p.kill()
            p.wait(30)
    assert sweep.returncode == 3, err
    assert f"lost the Dask scheduler at {address}" in err and "run the same command again" in err, err
    done = _rows(out / "trials.csv")
    assert 1 <= len(done) < 6 and all(not r["error"] for r in done)
    assert main(["sweep", str(scenario), *grid, "--workers", "2", "--out", str(out), "--quiet"]) == 0
    rows = _rows(out / "trials.csv")
    assert len(rows) == 6 and len({(r["radio.loss"], r["trial"]) for r in rows}) == 6
    assert [r for r in rows if (r["radio.loss"], r["trial"]) in {(d["radio.loss"], d["trial"]) for d in done}] \
        == done  # the rows finished before the loss are kept as they were

"""The conformance kit: protocol families' suites, run against any implementation.

A protocol family (registered in the ``swarmactors.families`` entry-point
group) is a ``Family`` (``swarmactors.robot.family``): its name (the name reports go
under), its built-in behaviour, its report contract (the ``report()`` fields
its checks read, with their types) and its suite: a function ``suite(mode) -> list[Case]`` for
``mode`` "quick" or "full". A ``Case`` is data - a scenario (as parsed from
TOML) and the oracle checks it must pass - so the project's own tests, the
``swarmactors check`` command and the pytest plugin run the very same cases.

Running a case against a behaviour class: the family's behaviour in the
scenario is replaced by the class (its report still goes under the family's
name), the scenario runs in lockstep or realtime as the case says, the report
contract is checked, then the oracle checks; a lockstep case is run a second
time with two host processes and must give the same trace hash (hidden global
state, wall-clock use or unseeded randomness would show there). A failed case
leaves a scenario file that ``swarmactors run`` reproduces exactly.
"""

from __future__ import annotations

import asyncio
import copy
import inspect
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np
import tomli_w

from swarmactors.oracle.trace import canonical, read_trace
from swarmactors.robot.family import Case, Family, comb, ladder, line, ring
from swarmactors.robot.plugins import BEHAVIORS, FAMILIES, PluginError, available, resolve
from swarmactors.robot.plugins import families as registered_families
from swarmactors.runs.scenario import resolve_scenario, to_raw

__all__ = ["FAMILIES", "Case", "CaseResult", "ContractError", "Family", "check", "comb", "families", "ladder", "line",
           "random_geometric", "ring", "run_case"]


@dataclass
class CaseResult:
    family: str
    case: str
    passed: bool
    outcomes: list[dict] = field(default_factory=list)
    seed: int | None = None
    trace_hash: str | None = None
    reproduce: str | None = None  # scenario file that reproduces a failure (absolute path)
    reproduce_command: str | None = None  # the shell command that reproduces it, from any directory
    first_tick: int | None = None
    error: str | None = None
    wall_s: float = 0.0  # the whole case: every run, the oracle checks, the reproduction file


class ContractError(ValueError):
    """An implementation that does not speak the family's report contract (or cannot be loaded)."""


# ------------------------------------------------------------------ graph families
def random_geometric(n: int, seed: int, degree: float = 4.0, radius: float = 1.0) -> list[list[float]]:
    """A connected random geometric graph: n robots uniform in a square, ~``degree`` neighbours in ``radius``."""
    from swarmactors.runs.scenario import draw_until_connected

    side = math.sqrt(n * math.pi * radius**2 / degree)
    rng = np.random.default_rng([seed, n])
    try:
        pts = draw_until_connected(lambda: rng.random((n, 2)) * side, radius, attempts=500)
    except ValueError:
        raise ValueError(f"no connected random geometric graph with n={n}") from None
    return np.round(pts, 6).tolist()


# ------------------------------------------------------------------ families
def families() -> dict[str, Family]:
    """Every registered family that has a conformance suite, by name (``swarmactors.robot.plugins.families``)."""
    return {name: fam for name, fam in registered_families().items() if fam.suite is not None}


def behavior_path(cls_or_path: type | str) -> str:
    """``module:Class`` for a class (or a path/short name as given)."""
    if isinstance(cls_or_path, str):
        return cls_or_path
    return f"{cls_or_path.__module__}:{cls_or_path.__qualname__}"


def load_behavior(path: str) -> type:
    """Import a user's behaviour class; ``ContractError`` naming it when that fails."""
    try:
        cls = resolve(BEHAVIORS, path)
    except PluginError as exc:
        raise ContractError(f"--behavior {path}: {exc}") from None
    if not inspect.isclass(cls):
        raise ContractError(f"--behavior {path}: {cls!r} is not a class")
    return cls


def prepare(family: Family, case: Case, behavior: str | None, clock: str | None = None) -> dict:
    """The case's scenario with the family's behaviour replaced by ``behavior`` (reports keep the family name)."""
    raw = copy.deepcopy(case.scenario)
    for group in raw["robots"]:
        for spec in group.get("behaviors", []):
            if spec["use"] == family.behavior:
                spec["as"] = family.name
                if behavior is not None:
                    spec["use"] = behavior
    raw["checks"] = copy.deepcopy(case.checks)
    if clock is not None:
        raw.setdefault("run", {})["clock"] = clock
    raw.setdefault("run", {})["name"] = case.name.replace("/", "-")
    return raw


def check_contract(family: Family, behavior: str, reports: dict[int, dict]) -> None:
    """Every robot's report under the family's name has the contract's fields with the right types."""
    if not reports:
        raise ContractError(f"{behavior}: no robot reported under {family.name!r}")
    for rid, rep in sorted(reports.items()):
        if "report_error" in rep:
            raise ContractError(f"{behavior}.report() raised on robot {rid}: {rep['report_error']}")
        for key, typ in family.report.items():
            if key not in rep:
                raise ContractError(f"{behavior}.report() lacks field {key!r} (robot {rid}; "
                                    f"the {family.name} contract needs {sorted(family.report)})")
            types = typ if isinstance(typ, tuple) else (typ,)
            if not isinstance(rep[key], types) or (isinstance(rep[key], bool) and bool not in types):
                names = " or ".join(t.__name__ for t in types)
                raise ContractError(f"{behavior}.report() field {key!r} is {type(rep[key]).__name__}, "
                                    f"expected {names} (robot {rid})")


def is_user_behavior(behavior: str | None) -> bool:
    """A ``module:Class`` that is not one of the registered (shipped or installed) behaviours."""
    return behavior is not None and ":" in behavior and behavior not in available(BEHAVIORS).values()


def run_case(family: Family, case: Case, behavior: str | None, out_dir: Path, clock: str | None = None,
             determinism: bool = True) -> CaseResult:
    """Run one case against ``behavior`` (None: the built-in one) and judge it.

    A user's behaviour runs in a host process (K = 1): one that hangs or allocates without bound then costs its
    robots, not the world (docs/writing-behaviors.md); the built-in ones run in the world's process (K = 0).
    """
    from swarmactors.runs.launcher import new_run_id, run_world
    from transport import Endpoints

    t0 = time.perf_counter()
    raw = prepare(family, case, behavior, clock)
    sc = resolve_scenario(raw, f"<case {case.name}>")
    case_dir = out_dir / case.name.replace("/", "-")
    k = 1 if is_user_behavior(behavior) else 0
    result = asyncio.run(run_world(sc, case_dir / f"k{k}", Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                                   new_run_id(sc["run"]["name"]), processes=k))
    label = behavior or family.behavior
    check_contract(family, label, result.reports(family.name))
    outcomes = result.checks
    first = [o["first_tick"] for o in outcomes if not o["passed"] and o["first_tick"] is not None]
    if determinism and case.determinism and sc["run"]["clock"] == "lockstep":
        other = asyncio.run(run_world(sc, case_dir / "k2", Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                                      new_run_id(sc["run"]["name"]), processes=2))
        same = other["trace_hash"] == result["trace_hash"]
        tick = None if same else first_difference(result.trace_path, other.trace_path)
        outcomes = outcomes + [{
            "name": "determinism", "passed": same, "value": f"K=2 {other['trace_hash'][:12]}",
            "bound": f"K={k} {result['trace_hash'][:12]}",
            "detail": "" if same else f"trace differs with 2 host processes from tick {tick}",
            "first_tick": tick}]
        if not same:
            first.append(tick)
    passed = all(o["passed"] for o in outcomes)
    res = CaseResult(family.name, case.name, passed, outcomes, seed=sc["run"]["seed"],
                     trace_hash=result["trace_hash"], first_tick=min(first) if first else None)
    if not passed:
        path = case_dir / "reproduce.toml"
        path.write_text(f"# swarmactors check: case {case.name} failed; `swarmactors run {path.name}` "
                        f"reproduces it\n" + tomli_w.dumps(_tomlable(to_raw(sc))))
        res.reproduce = str(path.resolve())
        res.reproduce_command = reproduce_command(res.reproduce, behavior)
    res.wall_s = time.perf_counter() - t0
    return res


def reproduce_command(scenario: str, behavior: str | None) -> str:
    """``swarmactors run FILE``, with ``PYTHONPATH`` naming the folder of a user's ``module:Class`` if needed.

    The command then works from any directory: the file is absolute, and the module is found where it was.
    """
    import importlib.util
    import shlex

    command = f"swarmactors run {shlex.quote(scenario)}"
    if not is_user_behavior(behavior):
        return command
    module = behavior.partition(":")[0]
    try:
        spec = importlib.util.find_spec(module)
    except (ImportError, ValueError):
        return command
    if spec is None or not spec.origin or spec.origin in ("built-in", "frozen"):
        return command
    root = Path(spec.origin).resolve().parent
    for _ in range(module.count(".") + (1 if Path(spec.origin).name == "__init__.py" else 0)):
        root = root.parent
    if "site-packages" in root.parts:  # installed: importable from anywhere
        return command
    return f"PYTHONPATH={shlex.quote(str(root))} {command}"


def first_difference(a: Path | None, b: Path | None) -> int | None:
    """The first tick whose canonical records differ between two traces."""
    if a is None or b is None:
        return None
    _, ra, _ = read_trace(a)
    _, rb, _ = read_trace(b)
    for x, y in zip(ra, rb, strict=False):
        if canonical(x) != canonical(y):
            return x["t"]
    return min(len(ra), len(rb)) if len(ra) != len(rb) else None


def _tomlable(obj: Any) -> Any:
    """Drop None values (TOML has no null); keep everything else."""
    if isinstance(obj, dict):
        return {k: _tomlable(v) for k, v in obj.items() if v is not None}
    if isinstance(obj, list):
        return [_tomlable(v) for v in obj]
    return obj


def select(family_name: str, mode: str) -> list[tuple[Family, Case]]:
    """The (family, case) pairs of one family or ``all``."""
    fams = families()
    if family_name != "all" and family_name not in fams:
        raise ContractError(f"unknown family {family_name!r} (known: {', '.join(sorted(fams))}, all)")
    chosen = fams.values() if family_name == "all" else [fams[family_name]]
    return [(f, c) for f in chosen for c in f.suite(mode)]


def case_by_name(family_name: str, case_name: str, mode: str = "quick") -> tuple[Family, Case]:
    for fam, case in select(family_name, mode):
        if case.name == case_name:
            return fam, case
    raise KeyError(f"no case {case_name!r} in family {family_name!r} ({mode})")


def junit_xml(results: list[CaseResult], behavior: str) -> str:
    """JUnit XML: one testcase per case, a failure element with the failed checks."""
    import xml.etree.ElementTree as ET

    suite = ET.Element("testsuite", name=f"swarmactors conformance ({behavior})", tests=str(len(results)),
                       failures=str(sum(not r.passed and not r.error for r in results)),
                       errors=str(sum(bool(r.error) for r in results)),
                       time=f"{sum(r.wall_s for r in results):.3f}")
    for r in results:
        tc = ET.SubElement(suite, "testcase", classname=r.family, name=r.case, time=f"{r.wall_s:.3f}")
        if r.error:
            ET.SubElement(tc, "error", message=r.error).text = r.error
        elif not r.passed:
            failed = [o for o in r.outcomes if not o["passed"]]
            msg = "; ".join(f"{o['name']}: value {o['value']} bound {o['bound']}" for o in failed)
            text = "\n".join(f"{o['name']}: {o['detail']}" for o in failed)
            text += f"\nseed {r.seed}, first tick {r.first_tick}\nreproduce: {r.reproduce_command}"
            ET.SubElement(tc, "failure", message=msg).text = text
    return ET.tostring(suite, encoding="unicode", xml_declaration=True)


def _job(family_name: str, case_name: str, mode: str, behavior: str | None, out_dir: str,
         determinism: bool) -> dict:
    """One case in a worker process (top level, so that the spawn start method can pickle it)."""
    import logging

    logging.getLogger().setLevel(logging.ERROR)
    fam, case = case_by_name(family_name, case_name, mode)
    t0 = time.perf_counter()
    try:
        return asdict(run_case(fam, case, behavior, Path(out_dir), determinism=determinism))
    except ContractError as exc:
        return asdict(CaseResult(fam.name, case.name, False, error=f"contract: {exc}",
                                 wall_s=time.perf_counter() - t0))
    except Exception as exc:  # a case that cannot run is a failed case, with the reason
        return asdict(CaseResult(fam.name, case.name, False, error=f"{exc.__class__.__name__}: {exc}",
                                 wall_s=time.perf_counter() - t0))


def _cluster_job(family_name: str, case_name: str, mode: str, behavior: str | None, determinism: bool, *,
                 out: Path) -> tuple[dict, bool]:
    """One case in a child process on a Dask worker (``swarmactors.runs.cluster``): (its result, keep files: failed)."""
    d = _job(family_name, case_name, mode, behavior, str(out.parent / "cases"), determinism)
    case_dir = out.parent / "cases" / case_name.replace("/", "-")
    if case_dir.is_dir():
        case_dir.rename(out)
    for k in ("reproduce", "reproduce_command"):
        if d.get(k):
            d[k] = d[k].replace(str(case_dir.resolve()), str(out.resolve()))
    return d, not d["passed"]


def _on_cluster(address: str, args: list[tuple], behavior: str | None, out_dir: Path, take) -> None:
    """The cases as tasks on a Dask cluster, each in a fresh child process (``swarmactors.runs.cluster``)."""
    from swarmactors.runs import cluster as cl

    client = cl.connect(address)
    try:
        cl.require_modules(client, cl.user_modules([behavior] if behavior else []))
        jobs = [cl.Job(a, "swarmactors.runs.conformance:_cluster_job", (a[0], a[1], a[2], a[3], a[5]), name="case")
                for a in args]

        def on_reply(job: cl.Job, reply: cl.Reply) -> None:
            if reply.error is not None:
                take(asdict(CaseResult(job.key[0], job.key[1], False, error=reply.error)))
                return
            d = dict(reply.value)
            case_dir = (out_dir / d["case"].replace("/", "-")).resolve()
            if reply.files:
                cl.extract(reply.files, case_dir)
            for k in ("reproduce", "reproduce_command"):
                if d.get(k):
                    d[k] = d[k].replace(str(Path(reply.tmp).resolve()), str(case_dir))
            take(d)

        if cl.run_jobs(client, jobs, on_reply):
            raise KeyboardInterrupt
    finally:
        client.close()


def check(family_name: str = "all", behavior: str | None = None, mode: str = "quick", clock: str | None = None,
          jobs: int = 1, out_dir: Path = Path("out/check"), determinism: bool = True,
          progress: Callable[[CaseResult], None] | None = None, cluster: str | None = None) -> list[CaseResult]:
    """Run a family's (or every family's) suite against ``behavior``; results in suite order.

    ``cluster``: a Dask scheduler's address (``tcp://HOST:8786``): the cases run on its workers, not here.
    ``ContractError`` when the behaviour cannot be loaded or does not speak the report contract.
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    if behavior is not None:
        load_behavior(behavior)
    pairs = select(family_name, mode)
    if clock is not None:
        pairs = [(f, c) for f, c in pairs if c.scenario.get("run", {}).get("clock", "lockstep") == clock]
    out_dir.mkdir(parents=True, exist_ok=True)
    args = [(f.name, c.name, mode, behavior, str(out_dir), determinism) for f, c in pairs]
    results: dict[tuple[str, str], CaseResult] = {}

    def take(d: dict) -> None:
        r = CaseResult(**d)
        if r.error and r.error.startswith("contract: "):
            raise ContractError(r.error[len("contract: "):])
        results[(r.family, r.case)] = r
        if progress:
            progress(r)

    if cluster is not None:
        _on_cluster(cluster, args, behavior, out_dir, take)
    elif jobs <= 1:
        for a in args:
            take(_job(*a))
    else:
        with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = [pool.submit(_job, *a) for a in args]
            try:
                for fut in as_completed(futures):
                    take(fut.result())
            except ContractError:
                for fut in futures:
                    fut.cancel()
                raise
    return [results[(f.name, c.name)] for f, c in pairs]


def as_dict(r: CaseResult) -> dict:
    return asdict(r)

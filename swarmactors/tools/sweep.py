"""Parameter sweeps: a grid of overrides × repeated trials over worker processes, one CSV row per trial.

``swarmactors sweep SCENARIO --grid radio.loss=0,0.1,0.2 --grid robots.0.count=20,40 --trials 5``
runs every combination of the grid's values (a *point*) ``trials`` times. The
trial with index i of every point runs with seed ``trial_seed(base, i)``, base
being the scenario's ``run.seed`` (after ``--seed``/``--set``), so every point
sees the same placements and loss draws (common random numbers), and the
sweep's rows are a function of its inputs alone.

Output (``--out DIR``, default ``out/<run.name>-sweep``):

* ``trials.csv`` - one row per finished trial (columns in ``COLUMNS`` order,
  then ``metric.<behaviour>.<name>`` and ``check.<name>`` columns, sorted);
  no wall-clock value, so a re-run gives the same bytes;
* ``sweep.json`` - what identifies the sweep (scenario digest, overrides, grid
  keys), checked when the sweep is resumed;
* ``trials/<point>/t<i>/`` - each trial's result.json and trace (kept for
  failed trials only unless ``--keep all``);
* ``summary-<key>.png`` - each metric against each grid key, mean ± standard
  deviation over the trials, every trial as a dot.

Resuming: a sweep started again with the same scenario, overrides and grid
keys skips the trials already in ``trials.csv`` (more values or more trials
just add rows). A trial cut short by Ctrl-C leaves no row. Trials run in
processes started with the ``spawn`` method (Zenoh's runtime does not survive
``fork``), ``--workers`` at a time; with ``--cluster tcp://HOST:8786`` they run
as tasks on a Dask cluster instead, each in a fresh child process on its worker
(``swarmactors.runs.cluster``), and the CSV holds the same bytes.

A sweep file (``read_spec``) is a TOML file with one ``[sweep]`` table naming
the scenario and its ``set``, ``grid``, ``trials`` and ``out``:
``swarmactors sweep experiment.toml`` runs it. A sweep file may name a Python
callable instead of a scenario (``trial = "module:function"``, for trials that
are not runs, such as one MILP instance): each trial calls
``function(params, seed=…, trial=…)`` with the ``params`` table and the grid
point's values, and its returned dict becomes the row's ``metric.`` cells; a
returned ``"checks": {name: passed}`` also fills ``passed`` and ``check.<name>``,
so the summary counts a callable trial's failed checks as a run's.
"""

from __future__ import annotations

import asyncio
import csv
import hashlib
import io
import itertools
import json
import math
import multiprocessing
import os
import queue
import re
import shutil
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from swarmactors.oracle.result import to_jsonable
from swarmactors.runs.launcher import fixed_hash_seed
from world.linkrules import DROP_CAUSES

COLUMNS_AFTER_GRID = ["trial", "seed", "ticks", "trace_hash", "stop_reason", "robots", "alive", "crashed",
                      "frames_sent",
                      "deliveries", *[f"dropped.{c}" for c in DROP_CAUSES], "dropped_total", "passed", "error"]
CALLABLE_COLUMNS_AFTER_GRID = ["trial", "seed", "error"]
SWEEP_VERSION = 1


class SweepError(ValueError):
    """A sweep that cannot start (bad --grid, an output directory holding another sweep, …)."""


@dataclass(frozen=True)
class Trial:
    point: int  # index of the grid point
    values: tuple  # the grid values of this point, in --grid order
    trial: int
    seed: int

    def key(self, keys: list[str]) -> tuple[str, ...]:
        return (*[cell(v) for v in self.values], str(self.trial))


@dataclass
class Sweep:
    scenario: Path
    overrides: list[str]
    grid: list[tuple[str, list]]  # (key, values) in --grid order
    trials: int
    out: Path
    base_seed: int
    name: str
    identity: dict = field(default_factory=dict)
    post: str | None = None  # a sweep file's post-processing function, "module:function"
    trial_fn: str | None = None  # a callable sweep's trial function, "module:function" (no scenario)
    params: dict = field(default_factory=dict)  # a callable sweep's fixed parameters

    @property
    def keys(self) -> list[str]:
        return [k for k, _ in self.grid]

    @property
    def columns_after_grid(self) -> list[str]:
        return CALLABLE_COLUMNS_AFTER_GRID if self.trial_fn else COLUMNS_AFTER_GRID

    @property
    def csv_path(self) -> Path:
        return self.out / "trials.csv"

    def all_trials(self) -> list[Trial]:
        points = list(itertools.product(*[vals for _, vals in self.grid])) if self.grid else [()]
        return [Trial(p, tuple(vals), i, trial_seed(self.base_seed, i))
                for p, vals in enumerate(points) for i in range(self.trials)]

    def trial_dir(self, t: Trial) -> Path:
        return self.out / "trials" / point_slug(self.keys, t.values) / f"t{t.trial}"

    def trial_values(self, t: Trial) -> dict:
        """The values this trial sets on top of the overrides: its grid point's and its seed."""
        return {**dict(zip(self.keys, t.values, strict=True)), "run.seed": t.seed}

    def trial_params(self, t: Trial) -> dict:
        """A callable sweep's arguments for trial ``t``: the ``params`` table, then its grid point's values."""
        return {**self.params, **dict(zip(self.keys, t.values, strict=True))}


def load_point(scenario: str | Path, overrides: list[str], values: dict) -> dict:
    """The scenario with the ``--set`` overrides (text, as typed) and then ``values`` set as Python values.

    Grid values are set as the values ``parse_grid`` read, not written back to TOML text and parsed again.
    """
    from swarmactors.runs.scenario import apply_override, read_raw, resolve_scenario, set_value

    source = str(scenario)
    raw = read_raw(scenario)
    for item in overrides:
        apply_override(raw, item, source)
    for key, value in values.items():
        set_value(raw, key, value, source)
    return resolve_scenario(raw, source)


# ---------------------------------------------------------------- set-up
def parse_grid(item: str) -> tuple[str, list]:
    """``key=v1,v2,…`` (TOML values; bare words are strings) -> (key, [values])."""
    key, sep, text = item.partition("=")
    key = key.strip()
    if not sep or not key or not text.strip():
        raise SweepError(f"--grid {item!r}: expected SECTION.KEY=V1,V2,...")
    try:
        values = tomllib.loads(f"v = [{text}]")["v"]
    except tomllib.TOMLDecodeError:
        values = []
        for part in text.split(","):
            part = part.strip()
            try:
                values.append(tomllib.loads(f"v = {part}")["v"])
            except tomllib.TOMLDecodeError:
                values.append(part)
    if not values:
        raise SweepError(f"--grid {item!r}: no values")
    if len({cell(v) for v in values}) != len(values):
        raise SweepError(f"--grid {item!r}: a value is repeated")
    return key, values


def trial_seed(base: int, trial: int) -> int:
    """The seed of trial ``trial``: a fixed function of the base seed and the index (31 bits)."""
    digest = hashlib.blake2b(f"swarmactors-sweep/{base}/{trial}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "big") & 0x7FFF_FFFF


def point_slug(keys: list[str], values: tuple) -> str:
    if not keys:
        return "base"
    text = ",".join(f"{k}={cell(v)}" for k, v in zip(keys, values, strict=True))
    return re.sub(r"[^A-Za-z0-9_.=,+-]", "_", text)[:150]


def prepare(scenario: str | Path, overrides: list[str], grid_items: list[str | tuple], trials: int,
            out: Path | None) -> Sweep:
    """Validate everything (every grid point resolves) before any trial starts."""
    from swarmactors.runs.scenario import load

    if trials < 1:
        raise SweepError(f"--trials {trials}: must be >= 1")
    grid = [item if isinstance(item, tuple) else parse_grid(item) for item in grid_items]
    keys = [k for k, _ in grid]
    if len(set(keys)) != len(keys):
        raise SweepError("--grid: a key is given twice")
    base = load(scenario, overrides)  # ScenarioError names the file and the key
    for key, values in grid:
        for v in values:
            load_point(scenario, overrides, {key: v})
    digest_src = {k: v for k, v in to_jsonable(base).items() if k != "source"}
    identity = {
        "version": SWEEP_VERSION,
        "scenario": str(scenario),
        "scenario_digest": hashlib.blake2b(json.dumps(digest_src, sort_keys=True).encode(),
                                           digest_size=16).hexdigest(),
        "overrides": list(overrides),
        "grid_keys": keys,
    }
    name = base["run"]["name"]
    return Sweep(Path(scenario), list(overrides), grid, trials, out or Path("out") / f"{name}-sweep",
                 base["run"]["seed"], name, identity)


def plan(source: str | Path, overrides: list[str], grid_items: list[str], trials: int | None,
         out: Path | None) -> Sweep:
    """The sweep of the command line: ``source`` is a scenario or a sweep file (``read_spec``).

    The options extend a sweep file's values (``--set``, ``--grid``) or replace them (``--trials``, ``--out``).
    """
    spec = read_spec(source)
    if spec is None:
        return prepare(source, overrides, grid_items, 1 if trials is None else trials, out)
    grid = _merged_grid(spec["grid"], grid_items)
    if spec["trial"] is not None:
        sw = prepare_callable(source, spec, overrides, grid, trials, out)
    else:
        sw = prepare(spec["scenario"], [*spec["set"], *overrides], grid,
                     spec["trials"] if trials is None else trials, out or spec["out"])
    sw.post = spec["post"]
    if sw.post:
        _load_function(sw.post, source)  # a post function that cannot load stops the sweep before it starts
    return sw


def prepare_callable(source: str | Path, spec: dict, overrides: list[str], grid_items: list[str | tuple],
                     trials: int | None, out: Path | None) -> Sweep:
    """A sweep of a Python callable (``trial = "module:function"``): no scenario, ``params`` instead of ``set``.

    ``--set KEY=VALUE`` sets ``params.KEY`` (a TOML value) and ``--seed`` the base seed; ``--clock`` is refused.
    """
    params = dict(spec["params"])
    base_seed = spec["seed"]
    for item in overrides:
        key, _, text = item.partition("=")
        if key == "run.seed":
            base_seed = _toml_value(text, item)
            if type(base_seed) is not int:
                raise SweepError(f"--seed {text}: must be an integer")
        elif key.startswith("run."):
            raise SweepError(f"{source}: --set {item!r}: a sweep of {spec['trial']} has no scenario (only "
                             "--seed, --grid and --set of its params apply)")
        else:
            params[key] = _toml_value(text, item)
    grid = [item if isinstance(item, tuple) else parse_grid(item) for item in grid_items]
    keys = [k for k, _ in grid]
    if len(set(keys)) != len(keys):
        raise SweepError("--grid: a key is given twice")
    n = spec["trials"] if trials is None else trials
    if n < 1:
        raise SweepError(f"--trials {n}: must be >= 1")
    _load_function(spec["trial"], source, "trial")  # a trial function that cannot load stops the sweep now
    name = Path(source).stem
    identity = {"version": SWEEP_VERSION, "trial": spec["trial"], "params": params, "seed": base_seed,
                "grid_keys": keys}
    return Sweep(Path(source), [], grid, n, out or spec["out"] or Path("out") / f"{name}-sweep", base_seed, name,
                 identity, trial_fn=spec["trial"], params=params)


def _toml_value(text: str, item: str):
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        if re.fullmatch(r"[\w.-]+", text):
            return text  # a bare word is a string, as in --grid
        raise SweepError(f"--set {item!r}: the value is not TOML") from None


def _merged_grid(file_grid: list[tuple], items: list[str]) -> list[tuple]:
    """The sweep file's grid, then the ``--grid`` options: an option for a key of the file replaces its values."""
    grid = dict(file_grid)
    for item in items:
        key, values = parse_grid(item)
        grid[key] = values
    return list(grid.items())


SPEC_KEYS = {"scenario": "the scenario file, relative to this file", "set": "overrides, as --set",
             "grid": "a table of key = [values], as --grid", "trials": "runs per grid point",
             "out": "output directory (relative to the current directory)",
             "post": '"module:function" called as function(trials_csv, out_dir) after the sweep (a figure)',
             "trial": '"module:function" called as function(params, seed=, trial=) -> dict, instead of a scenario',
             "params": "a callable sweep's fixed arguments (a table)",
             "seed": "a callable sweep's base seed (an integer; default 1)"}
SCENARIO_ONLY, CALLABLE_ONLY = {"scenario", "set"}, {"trial", "params", "seed"}


def read_spec(path: str | Path) -> dict | None:
    """A sweep file: TOML with one ``[sweep]`` table (``SPEC_KEYS``); None when ``path`` is a scenario.

    ``SweepError`` naming the file and the key for an unknown key or a value of the wrong type.
    """
    from swarmactors.runs.scenario import read_raw

    raw = read_raw(path)  # ScenarioError naming the file
    if "sweep" not in raw:
        return None
    for key in raw:
        if key != "sweep":
            raise SweepError(f"{path}: unknown key {key!r} (a sweep file holds only a [sweep] table)")
    spec = raw["sweep"]
    if not isinstance(spec, dict):
        raise SweepError(f"{path}: key 'sweep' must be a table")
    for key in spec:
        if key not in SPEC_KEYS:
            raise SweepError(f"{path}: unknown key 'sweep.{key}' (known: {', '.join(SPEC_KEYS)})")

    def bad(key: str, what: str):
        return SweepError(f"{path}: key 'sweep.{key}' = {spec.get(key)!r}: must be {what}")

    trial = spec.get("trial")
    if trial is not None:
        if not (isinstance(trial, str) and re.fullmatch(r"[\w.]+:\w+", trial)):
            raise bad("trial", '"module:function"')
        for key in SCENARIO_ONLY & set(spec):
            raise SweepError(f"{path}: key 'sweep.{key}': a sweep names either a scenario or a trial function")
    else:
        for key in CALLABLE_ONLY & set(spec):
            raise SweepError(f"{path}: key 'sweep.{key}' belongs to a sweep of a trial function "
                             "(give 'sweep.trial')")
        if not isinstance(spec.get("scenario"), str):
            raise bad("scenario", "a scenario file name")
    params = spec.get("params", {})
    if not isinstance(params, dict):
        raise bad("params", "a table")
    seed = spec.get("seed", 1)
    if type(seed) is not int:
        raise bad("seed", "an integer")
    sets = spec.get("set", [])
    if not (isinstance(sets, list) and all(isinstance(x, str) and "=" in x for x in sets)):
        raise bad("set", 'a list of "SECTION.KEY=VALUE" strings')
    grid = spec.get("grid", {})
    if not (isinstance(grid, dict) and all(isinstance(v, list) and v for v in grid.values())):
        raise bad("grid", "a table of key = [values] (non-empty lists)")
    items = []
    for key, values in grid.items():
        if len({cell(v) for v in values}) != len(values):
            raise bad("grid", f"values without repeats (sweep.grid.{key} repeats one)")
        items.append((key, values))
    trials = spec.get("trials", 1)
    if type(trials) is not int or trials < 1:
        raise bad("trials", "an integer >= 1")
    if "out" in spec and not isinstance(spec["out"], str):
        raise bad("out", "a directory name")
    post = spec.get("post")
    if post is not None and not (isinstance(post, str) and re.fullmatch(r"[\w.]+:\w+", post)):
        raise bad("post", '"module:function"')
    scenario = Path(path).parent / spec["scenario"] if trial is None else None
    return {"scenario": scenario, "set": sets, "grid": items, "trials": trials,
            "out": Path(spec["out"]) if "out" in spec else None, "post": post, "trial": trial, "params": params,
            "seed": seed}


# ---------------------------------------------------------------- one trial
def trial_run_id(sw: Sweep, t: Trial) -> str:
    """The trial's run id: a function of the sweep's identity and the trial's key (the same on any machine)."""
    return f"sweep-{hashlib.blake2b(repr((sw.identity, t.key(sw.keys))).encode(), digest_size=6).hexdigest()}"


def base_row(sw: Sweep, t: Trial) -> dict:
    row = {k: cell(v) for k, v in zip(sw.keys, t.values, strict=True)}
    row.update(trial=str(t.trial), seed=str(t.seed))
    return row


def run_trial(sweep_args: dict, t: Trial) -> dict | None:
    """Run one trial (in a worker process); return its CSV row (cells as strings), or None if interrupted."""
    sw: Sweep = sweep_args["sweep"]
    row = base_row(sw, t)
    if sw.trial_fn:
        row.update(callable_cells(sw.trial_fn, sw.trial_params(t), t.seed, t.trial)[0])
        return row
    out_dir = sw.trial_dir(t)
    if out_dir.exists():
        shutil.rmtree(out_dir)  # a trial cut short before: start it afresh
    try:
        sc = load_point(sw.scenario, sw.overrides, sw.trial_values(t))
    except Exception as exc:  # the row says why; the sweep goes on
        row["error"] = f"{exc.__class__.__name__}: {exc}"
        return row
    cells, keep = trial_cells(sc, out_dir, trial_run_id(sw, t), sweep_args["keep"])
    if cells is None:
        return None
    row.update(cells)
    if not keep:
        shutil.rmtree(out_dir, ignore_errors=True)
    return row


def callable_cells(ref: str, params: dict, seed: int, trial: int, *, out: Path | None = None) -> tuple[dict, bool]:
    """One trial of a callable sweep: ``function(params, seed=, trial=)``'s dict as ``metric.`` cells (no files).

    A function that raises, or returns something else than a dict, gives an ``error`` cell: the sweep goes on.
    """
    try:
        value = _load_function(ref, "the sweep file", "trial")(dict(params), seed=seed, trial=trial)
        if not isinstance(value, dict):
            raise TypeError(f"{ref} returned {type(value).__name__}, not a dict of metrics")
    except Exception as exc:  # the row says why; the sweep goes on
        return {"error": f"{exc.__class__.__name__}: {exc}"}, False
    row = {"error": "", **{f"metric.{k}": cell(v) for k, v in _flatten(value)}}
    checks = value.get("checks")
    if isinstance(checks, dict) and checks and all(isinstance(v, bool) for v in checks.values()):
        # a returned {"checks": {name: passed}} is the trial's verdict, as a scenario run's checks are
        row["passed"] = cell(all(checks.values()))
        for name, ok in checks.items():
            row[f"check.{name}"] = "pass" if ok else "fail"
    return row, False


def returned_values(csv_path: str | Path) -> list[dict]:
    """A callable sweep's trials.csv read back: for each row without an error, the dict its trial function returned.

    The inverse of the ``metric.`` cells (nested keys rebuilt from the dots, numbers, booleans, lists and empty
    cells as values), in the CSV's order: what a sweep file's ``post`` function draws its figure from.
    """
    out = []
    with open(csv_path, newline="") as f:
        for row in csv.DictReader(f):
            if row.get("error"):
                continue
            value: dict = {}
            for column, text in row.items():
                if column.startswith("metric."):
                    *path, leaf = column.removeprefix("metric.").split(".")
                    node = value
                    for part in path:
                        node = node.setdefault(part, {})
                    node[leaf] = _uncell(text)
            out.append(value)
    return out


def _uncell(text: str):
    if text == "":
        return None
    if text in ("true", "false"):
        return text == "true"
    if text[:1] in "[{":
        return json.loads(text)
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def cluster_trial(sc: dict, run_id: str, keep: str, *, out: Path) -> tuple[dict | None, bool]:
    """One trial in a child process on a Dask worker (``swarmactors.runs.cluster.in_child``): as ``trial_cells``."""
    return trial_cells(sc, out, run_id, keep)


def trial_cells(sc: dict, out_dir: Path, run_id: str, keep: str) -> tuple[dict | None, bool]:
    """Run the resolved trial scenario ``sc`` into ``out_dir``: (its CSV cells, keep its files?); None if interrupted.

    A trial that raises gives an ``error`` cell (and keeps its files): the sweep goes on.
    """
    from swarmactors.runs.launcher import run_world
    from transport import Endpoints

    try:
        result = asyncio.run(run_world(sc, out_dir, Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]), run_id,
                                       processes=sc["run"]["processes"], return_on_signal=True))
    except Exception as exc:  # the row says why; the sweep goes on
        return {"error": f"{exc.__class__.__name__}: {exc}"}, True
    if result["interrupted"]:
        return None, False
    from swarmactors.exitcodes import crashed

    data = result.data
    w = data["world"]
    row = dict(
        ticks=cell(data["ticks"]), trace_hash=data["trace_hash"], stop_reason=cell(data["stop_reason"]),
        robots=cell(len(data["robots"])), alive=cell(sum(1 for r in data["robots"].values() if r["alive"])),
        crashed=cell(sum(crashed(r) for r in data["robots"].values())),
        frames_sent=cell(w["frames_sent"]), deliveries=cell(w["deliveries"]),
        dropped_total=cell(w["dropped_total"]),
        passed=cell(all(c["passed"] for c in data["checks"])) if data["checks"] else "",
        error="",
    )
    for c in DROP_CAUSES:
        row[f"dropped.{c}"] = cell(w["dropped"].get(c, 0))
    for beh, metrics in sorted(data["metrics"].items()):
        for k, v in _flatten(metrics):
            row[f"metric.{beh}.{k}"] = cell(v)
    for c in data["checks"]:  # a check with several outcomes: fail if any fails, with the first failure's value
        if row.get(f"check.{c['name']}") == "fail":
            continue
        row[f"check.{c['name']}"] = "pass" if c["passed"] else "fail"
        row[f"check.{c['name']}.value"] = cell(c["value"])
    failed = row["passed"] == "false" or row["crashed"] != "0"
    return row, keep == "all" or (keep == "failed" and failed)


def _flatten(d: dict, prefix: str = ""):
    for k, v in sorted(d.items(), key=lambda kv: str(kv[0])):
        name = f"{prefix}{k}"
        if isinstance(v, dict) and v and all(not isinstance(x, (dict, list)) for x in v.values()):
            yield from _flatten(v, name + ".")
        else:
            yield name, v


def cell(v) -> str:
    """A CSV cell: the same value always gives the same text."""
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ""
    if isinstance(v, str):
        return v
    return json.dumps(to_jsonable(v), sort_keys=True, separators=(",", ":"))


def _worker(sweep_args: dict, tasks, results) -> None:
    """A worker process: run trials until told to stop."""
    import logging

    logging.basicConfig(level=logging.ERROR)
    os.environ.setdefault("PYTHONHASHSEED", "0")
    while True:
        t = tasks.get()
        if t is None:
            return
        results.put((t, run_trial(sweep_args, t)))


# ---------------------------------------------------------------- the CSV
class Table:
    """trials.csv: rows kept in memory, appended as they come, rewritten in trial order at the end."""

    def __init__(self, sweep: Sweep):
        self.sweep = sweep
        self.path = sweep.csv_path
        self.rows: dict[tuple, dict] = {}
        self.header: list[str] = []
        self.order = {t.key(sweep.keys): i for i, t in enumerate(sweep.all_trials())}

    def load(self) -> int:
        """Read the rows already done; return how many. A torn last line (a killed sweep) is dropped."""
        if not self.path.exists():
            return 0
        text = self.path.read_text()
        reader = csv.reader(io.StringIO(text))
        try:
            header = next(reader)
        except StopIteration:
            return 0
        missing = [c for c in [*self.sweep.keys, "trial"] if c not in header]
        if missing:
            raise SweepError(f"{self.path}: no column {missing[0]!r}: this file belongs to another sweep")
        complete_lines = text.endswith("\n")
        rows = list(reader)
        for i, cells in enumerate(rows):
            if len(cells) != len(header) or (i == len(rows) - 1 and not complete_lines):
                continue
            row = dict(zip(header, cells, strict=True))
            self.rows[tuple(row[k] for k in [*self.sweep.keys, "trial"])] = row
        self.header = header
        self._rewrite()  # drop a torn line now, so appends start on a clean line
        return len(self.rows)

    def done(self, t: Trial) -> bool:
        return t.key(self.sweep.keys) in self.rows

    def add(self, t: Trial, row: dict) -> None:
        self.rows[t.key(self.sweep.keys)] = row
        header = self._header_for(self.rows.values())
        if header != self.header or not self.path.exists():
            self.header = header
            self._rewrite()
        else:
            with open(self.path, "a", newline="") as f:
                csv.writer(f, lineterminator="\n").writerow([row.get(c, "") for c in self.header])

    def finish(self) -> None:
        self.header = self._header_for(self.rows.values())
        self._rewrite()

    def _header_for(self, rows) -> list[str]:
        fixed = self.sweep.columns_after_grid
        extra = sorted({k for r in rows for k in r} - set(self.sweep.keys) - set(fixed))
        metrics = [k for k in extra if k.startswith("metric.")]
        checks = [k for k in extra if k.startswith("check.")]
        others = [k for k in extra if k not in metrics and k not in checks]
        return [*self.sweep.keys, *fixed, *metrics, *checks, *others]

    def _rewrite(self) -> None:
        def position(item):
            key, _ = item
            return (self.order.get(key, len(self.order)), key)

        tmp = self.path.with_suffix(".csv.tmp")
        with open(tmp, "w", newline="") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(self.header)
            for _, row in sorted(self.rows.items(), key=position):
                w.writerow([row.get(c, "") for c in self.header])
        tmp.replace(self.path)


# ---------------------------------------------------------------- running
@dataclass
class Outcome:
    total: int
    skipped: int
    ran: int
    errors: int
    failed: int
    interrupted: bool
    csv: Path
    plots: list[Path]
    failed_by_check: dict[str, int] = field(default_factory=dict)  # check outcome name -> trials it failed
    crashed: int = 0  # trials in which a robot crashed (swarmactors.exitcodes.crashed)
    first_error: str = ""  # the error of the first trial that could not run

    def as_dict(self) -> dict:
        return {"csv": str(self.csv), "trials": self.total, "skipped": self.skipped, "ran": self.ran,
                "errors": self.errors, "failed_checks": self.failed, "failed_by_check": self.failed_by_check,
                "crashed": self.crashed, "first_error": self.first_error, "interrupted": self.interrupted,
                "plots": [str(p) for p in self.plots]}

    @property
    def exit_code(self) -> int:
        """130 interrupted; 1 when a trial failed a check, crashed a robot or could not run; else 0."""
        from swarmactors.exitcodes import EXIT_CHECK, EXIT_INTERRUPTED, EXIT_OK

        if self.interrupted:
            return EXIT_INTERRUPTED
        return EXIT_CHECK if self.failed or self.errors or self.crashed else EXIT_OK


def run_sweep(sw: Sweep, workers: int = 1, keep: str = "failed",
              progress: Callable[[int, int, dict], None] | None = None, cluster: str | None = None) -> Outcome:
    """Run the trials not yet in the CSV; Ctrl-C stops the workers and keeps the finished rows.

    ``cluster``: the address of a Dask scheduler (``tcp://HOST:8786``) whose workers run the trials
    (``swarmactors.runs.cluster``) instead of ``workers`` local processes; the rows are the same bytes.
    ``progress(done, total, counts)``: counts has ``errors``, ``failed`` (checks) and ``running``.
    """
    if workers < 1:
        raise SweepError(f"--workers {workers}: must be >= 1")
    if keep not in ("all", "failed", "none"):
        raise SweepError(f"--keep {keep!r}: one of all, failed, none")
    client = None
    if cluster is not None:
        from swarmactors.runs.cluster import connect

        client = connect(cluster)  # before anything is written: an unreachable scheduler leaves no trace
    try:
        return _run_sweep(sw, workers, keep, progress, client)
    finally:
        if client is not None:
            client.close()


def _run_sweep(sw: Sweep, workers: int, keep: str, progress, client) -> Outcome:
    sw.out.mkdir(parents=True, exist_ok=True)
    ident_path = sw.out / "sweep.json"
    if ident_path.exists():
        try:
            before = json.loads(ident_path.read_text())
        except ValueError:
            before = None
        if before != sw.identity:
            raise SweepError(f"{sw.out} holds another sweep (other scenario, --set or --grid keys): "
                             f"give another --out, or delete {sw.out}")
    else:
        ident_path.write_text(json.dumps(sw.identity, indent=1) + "\n")
    table = Table(sw)
    table.load()
    trials = sw.all_trials()
    pending = [t for t in trials if not table.done(t)]
    skipped = len(trials) - len(pending)
    # a resumed sweep counts the errors and failed checks of the trials already in trials.csv too
    before = [table.rows[t.key(sw.keys)] for t in trials if table.done(t)]
    counts = {"errors": sum(bool(r.get("error")) for r in before),
              "failed": sum(r.get("passed") == "false" for r in before),
              "crashed": sum(r.get("crashed", "") not in ("", "0") for r in before), "running": 0}
    done = skipped

    def report() -> None:
        if progress:
            progress(done, len(trials), counts)

    def take(t: Trial, row: dict) -> None:
        nonlocal done
        table.add(t, row)
        counts["errors"] += bool(row.get("error"))
        counts["failed"] += row.get("passed") == "false"
        counts["crashed"] += row.get("crashed", "") not in ("", "0")
        done += 1
        report()

    def running(n: int) -> None:
        counts["running"] = n
        report()

    report()
    interrupted = False
    if pending and client is not None:
        from swarmactors.runs.cluster import ClusterError

        try:
            interrupted = _on_cluster(sw, pending, keep, client, take, running)
        except ClusterError as exc:
            table.finish()
            raise ClusterError(f"{exc}: the sweep stopped with {done} of {len(trials)} trials in {table.path}; "
                               "run the same command again to resume it") from None
    elif pending:
        interrupted = _on_pool(sw, pending, keep, workers, take, running)
    counts["running"] = 0
    table.finish()
    plots = [] if interrupted else summary_plots(sw, table)
    if sw.post and not interrupted:
        plots += post_process(sw)
    rows = [table.rows[t.key(sw.keys)] for t in trials if table.done(t)]
    by_check: dict[str, int] = {}
    for r in rows:
        for k, v in r.items():
            if k.startswith("check.") and not k.endswith(".value") and v == "fail":
                by_check[k.removeprefix("check.")] = by_check.get(k.removeprefix("check."), 0) + 1
    return Outcome(len(trials), skipped, done - skipped, counts["errors"], counts["failed"], interrupted,
                   table.path, plots, dict(sorted(by_check.items())),
                   sum(r.get("crashed", "") not in ("", "0") for r in rows),
                   next((r["error"] for r in rows if r.get("error")), ""))


def _on_pool(sw: Sweep, pending: list[Trial], keep: str, workers: int, take, running) -> bool:
    """The trials over ``workers`` local spawned processes; True if interrupted."""
    args = {"sweep": sw, "keep": keep}
    interrupted = False
    ctx = multiprocessing.get_context("spawn")
    tasks, results = ctx.Queue(), ctx.Queue()
    for t in pending:
        tasks.put(t)
    n = min(workers, len(pending))
    for _ in range(n):
        tasks.put(None)
    with fixed_hash_seed():
        procs = [ctx.Process(target=_worker, args=(args, tasks, results), name=f"sweep-worker-{i}")
                 for i in range(n)]
        for p in procs:
            p.start()
    remaining = len(pending)
    running(min(n, remaining))
    try:
        while remaining:
            try:
                t, row = results.get(timeout=0.5)
            except queue.Empty:
                if not any(p.is_alive() for p in procs):
                    raise RuntimeError("every sweep worker exited before the sweep was done") from None
                continue
            remaining -= 1
            if row is None:  # the trial was interrupted: no row
                interrupted = True
                continue
            running(min(n, remaining))
            take(t, row)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        for p in procs:
            if p.is_alive() and (interrupted or remaining):
                p.terminate()
        for p in procs:
            p.join(10)
            if p.is_alive():
                p.kill()
                p.join()
    return interrupted


def _on_cluster(sw: Sweep, pending: list[Trial], keep: str, client, take, running) -> bool:
    """The trials as tasks on the Dask cluster of ``client``; True if interrupted.

    Each point is resolved here (so workers need neither the scenario file nor its map files) and run in a
    fresh child on a worker; the kept files come back to ``trials/``. Modules of ``module:Class``
    references must be importable on every worker (checked first: ``WorkerSetupError``).
    """
    from swarmactors.runs import cluster as cl

    jobs, uses = [], set()
    if sw.trial_fn:
        cl.require_modules(client, cl.user_modules([sw.trial_fn]))
        jobs = [cl.Job(t, "swarmactors.tools.sweep:callable_cells", (sw.trial_fn, sw.trial_params(t), t.seed, t.trial),
                       name="trial") for t in pending]
    for t in pending if not sw.trial_fn else ():
        try:
            sc = load_point(sw.scenario, sw.overrides, sw.trial_values(t))
        except Exception as exc:  # as in the local pool: the row says why
            take(t, {**base_row(sw, t), "error": f"{exc.__class__.__name__}: {exc}"})
            continue
        uses |= {b.get("use") for g in sc["robots"] for b in g.get("behaviors", [])}
        uses |= {c.get("use") for c in sc.get("checks", [])}
        jobs.append(cl.Job(t, "swarmactors.tools.sweep:cluster_trial", (sc, trial_run_id(sw, t), keep), name="trial"))
    if not sw.trial_fn:
        cl.require_modules(client, cl.user_modules(uses))

    def on_reply(job: cl.Job, reply: cl.Reply) -> None:
        t: Trial = job.key
        row = base_row(sw, t)
        if reply.error is not None:
            row["error"] = reply.error
        elif reply.value is None:  # the child was interrupted: no row
            return
        else:
            row.update(reply.value)
        out_dir = sw.trial_dir(t)
        if reply.files:
            cl.extract(reply.files, out_dir)
        elif out_dir.exists():
            shutil.rmtree(out_dir)  # left by an earlier, interrupted attempt
        take(t, row)

    return cl.run_jobs(client, jobs, on_reply, running)


def post_process(sw: Sweep) -> list[Path]:
    """Call the sweep file's ``post`` function on trials.csv; the files it returns (a figure) join the plots."""
    made = _load_function(sw.post)(sw.csv_path, sw.out)
    return [Path(p) for p in (made or [])]


def _load_function(ref: str, source: str | Path = "the sweep file", key: str = "post") -> Callable:
    import importlib

    module, _, name = ref.partition(":")
    try:
        return getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError) as exc:
        raise SweepError(f"{source}: key 'sweep.{key}' = {ref!r}: cannot load it ({exc})") from None


# ---------------------------------------------------------------- summary plots
def _number(text: str) -> float | None:
    if text in ("true", "false"):
        return 1.0 if text == "true" else 0.0
    try:
        v = float(text)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def summary_plots(sw: Sweep, table: Table) -> list[Path]:
    """Each numeric metric against each grid key: mean ± s.d. over trials; one line per value of the other keys."""
    if not sw.grid or not table.rows:
        return []
    from swarmactors.tools.charts import PALETTE, style

    rows = list(table.rows.values())
    skip = {*sw.keys, "trial", "seed", "ticks", "robots", "alive"}
    metrics = [c for c in table.header if c not in skip
               and (c.startswith("metric.") or c in ("frames_sent", "deliveries", "dropped_total", "passed"))
               and not c.endswith(".value")
               and any(_number(r.get(c, "")) is not None for r in rows)]
    metrics = [m for m in metrics if len({r.get(m, "") for r in rows}) > 1 or m == "passed"][:12]
    if not metrics:
        return []
    out = []
    for key, values in sw.grid:
        numeric_x = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
        xs = {cell(v): (float(v) if numeric_x else i) for i, v in enumerate(values)}
        span = (max(xs.values()) - min(xs.values())) if len(xs) > 1 else 1.0
        spread = 0.025 * span if numeric_x else 0.12  # the trials' dots side by side around their grid value
        others = [k for k in sw.keys if k != key]
        other_values = [[cell(v) for v in vals] for k, vals in sw.grid if k != key]
        series = [s for s in itertools.product(*other_values)
                  if any(tuple(r.get(k, "") for k in others) == s for r in rows)]
        ncol = min(3, len(metrics))
        nrow = math.ceil(len(metrics) / ncol)
        with style() as plt:
            fig, axes = plt.subplots(nrow, ncol, figsize=(4.0 * ncol, 3.0 * nrow), squeeze=False)
            for ax, m in zip(axes.flat, metrics, strict=False):
                for si, s in enumerate(series):
                    colour = PALETTE[si % len(PALETTE)]
                    px, mean, sd = [], [], []
                    for v in values:
                        ys = [_number(r.get(m, "")) for r in rows
                              if r.get(key) == cell(v) and tuple(r.get(k, "") for k in others) == s]
                        ys = [y for y in ys if y is not None]
                        if not ys:
                            continue
                        x = xs[cell(v)]
                        offsets = [spread * (2 * i / (len(ys) - 1) - 1) if len(ys) > 1 else 0.0
                                   for i in range(len(ys))]
                        ax.scatter([x + d for d in offsets], ys, s=16, color=colour, alpha=0.6,
                                   edgecolors="white", linewidths=0.4, zorder=3)
                        px.append(x)
                        mean.append(sum(ys) / len(ys))
                        sd.append(math.sqrt(sum((y - mean[-1]) ** 2 for y in ys) / len(ys)))
                    label = ", ".join(f"{k}={v}" for k, v in zip(others, s, strict=True)) if others else None
                    ax.errorbar(px, mean, yerr=sd, color=colour, marker="o", ms=4, lw=1.4, capsize=3, label=label)
                ax.set_title("pass rate (all checks)" if m == "passed" else m.removeprefix("metric."))
                if m == "passed":
                    ax.set_ylim(-0.05, 1.05)
                ax.set_xlabel(key)
                if not numeric_x:
                    ax.set_xticks(range(len(values)), [cell(v) for v in values])
                if others and ax is axes.flat[0]:
                    ax.legend(loc="best")
            for ax in list(axes.flat)[len(metrics):]:
                ax.set_visible(False)
            fig.suptitle(f"{sw.name}: metrics against {key} (mean ± s.d. over {sw.trials} trials; dots: trials)")
            fig.tight_layout()
            path = sw.out / f"summary-{re.sub(r'[^A-Za-z0-9_.-]', '_', key)}.png"
            fig.savefig(path)
            plt.close(fig)
            out.append(path)
    return out

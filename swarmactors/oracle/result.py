"""result.json: building it, and reading it back with helpers.

Schema (docs/result.md): ``scenario`` (resolved), ``run_id``, ``seed``,
``clock``, ``processes``, ``ticks``, ``wall_s``, ``version`` {package, commit},
``trace`` (file name or null), ``trace_hash``, ``trace_error``,
``interrupted``, ``stop_reason``, ``robots`` (id -> alive, pose, host,
joined_at, failed, status, frames {sent, received, dropped}, and each
behaviour's ``report()`` under its name), ``world`` (frames_sent, deliveries,
dropped by cause, dropped_total, malformed_examples), ``metrics`` (behaviour
name -> metrics), ``checks`` (list of {name, passed, value, bound, detail,
first_tick}).
"""

from __future__ import annotations

import json
import subprocess
from collections.abc import Iterator
from functools import cached_property
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from swarmactors.oracle.trace_tables import table_frame

if TYPE_CHECKING:  # networkx is the oracle's: imported where a graph is built, never by a robot host
    import networkx as nx


def package_version() -> dict:
    """The installed package version and, when known, the git commit of the source."""
    try:
        ver = version("swarmactors")
    except PackageNotFoundError:
        ver = "unknown"
    commit = None
    try:
        here = Path(__file__).resolve().parent
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=here, capture_output=True, text=True, timeout=5
        )
        if out.returncode == 0:
            commit = out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return {"package": ver, "commit": commit}


def to_jsonable(obj: Any) -> Any:
    """Make msgpack-decoded data JSON-safe: int keys to strings, bytes to hex, numpy to lists."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, bytes):
        return obj.hex()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


class Severed:
    """The oracle's replay of the trace's ``cut``, ``restore``, ``partition`` and ``heal`` events.

    Written apart from the product's rule (transport/severance.py, used by the radio and the charts) so that a
    bug in one does not hide in both; tests/unit/test_graph_at.py compares them. A link a–b is severed while the
    unordered pair is cut, or while a and b are in different partition groups (robots a partition does not list
    are in a group of their own, 0); ``heal`` ends both. Immutable: ``after(rec)`` returns the state after a
    tick's events.
    """

    __slots__ = ("cuts", "group")

    def __init__(self, cuts: frozenset = frozenset(), group: dict | None = None):
        self.cuts: frozenset = cuts
        self.group: dict[int, int] = group or {}

    def __bool__(self) -> bool:
        return bool(self.cuts or self.group)

    def __eq__(self, other) -> bool:
        return isinstance(other, Severed) and (self.cuts, self.group) == (other.cuts, other.group)

    __hash__ = None

    def after(self, rec: dict) -> Severed:
        cuts, group = self.cuts, self.group
        for ev in rec.get("ev", ()):
            if "cut" in ev:
                cuts = cuts | {frozenset(p) for p in ev["cut"]}
            elif "restore" in ev:
                cuts = cuts - {frozenset(p) for p in ev["restore"]}
            elif "partition" in ev:
                group = {r: k + 1 for k, members in enumerate(ev["partition"]) for r in members}
            elif "heal" in ev:
                cuts, group = frozenset(), {}
        return self if (cuts, group) == (self.cuts, self.group) else Severed(cuts, group)

    def between(self, a: int, b: int) -> bool:
        """Whether the link between robots ``a`` and ``b`` is severed (both directions)."""
        return frozenset((a, b)) in self.cuts or self.group.get(a, 0) != self.group.get(b, 0)


class ResultError(ValueError):
    """A result.json that cannot be used; the message names the file and the key."""


def result_problem(data: Any) -> str | None:
    """What is wrong with the shape of a result.json document (None: nothing); docs/result.md is the schema."""
    if not isinstance(data, dict):
        return f"the document is a {type(data).__name__}, not a map"
    shapes = {"scenario": dict, "robots": dict, "world": dict, "checks": list}
    for key, typ in shapes.items():
        if key in data and not isinstance(data[key], typ):
            return f"'{key}' is a {type(data[key]).__name__}, not a {typ.__name__}"
    for rid, robot in (data.get("robots") or {}).items():
        if not str(rid).lstrip("-").isdigit() or not isinstance(robot, dict):
            return f"robots[{rid!r}] is not a robot id with a map"
    for i, check in enumerate(data.get("checks") or []):
        if not isinstance(check, dict) or not isinstance(check.get("name"), str):
            return f"checks[{i}] is not a map with a name"
    return None


class Result:
    """A run's result.json with helpers (also what ``swarmactors.run`` returns)."""

    def __init__(self, data: dict, path: Path | None = None):
        self.data = data
        self.path = path
        self.signal: str | None = None  # "SIGINT" or "SIGTERM" when one came during or after the run (run_world)

    @classmethod
    def load(cls, path: str | Path) -> Result:
        """Read a run's result.json (or the one in a run directory); ResultError names the file and what is wrong."""
        path = Path(path)
        if path.is_dir():
            path = path / "result.json"
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except OSError as exc:
            raise ResultError(f"{path}: cannot read: {exc.strerror or exc}") from None
        except ValueError as exc:
            raise ResultError(f"{path}: not JSON: {exc}") from None
        problem = result_problem(data)
        if problem:
            raise ResultError(f"{path}: {problem}")
        return cls(data, path)

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    @property
    def robots(self) -> dict[int, dict]:
        return {int(k): v for k, v in self.data["robots"].items()}

    def behavior_params(self, name: str) -> dict:
        """The parameters of the behaviour whose report goes under ``name``, defaults filled in."""
        import inspect

        from swarmactors.robot.plugins import BEHAVIORS, resolve

        for g in self.data["scenario"]["robots"]:
            for spec in g["behaviors"]:
                if spec.get("as") == name:
                    sig = inspect.signature(resolve(BEHAVIORS, spec["use"]))
                    defaults = {k: p.default for k, p in sig.parameters.items()
                                if p.default is not inspect.Parameter.empty}
                    return defaults | {k: v for k, v in spec.items() if k not in ("use", "as")}
        raise KeyError(f"no behaviour reports as {name!r} in this scenario")

    def frame_counts(self, rid: int) -> dict:
        """Robot ``rid``'s frame counters from result.json: sent, received, overheard, dropped by cause (as sender)."""
        return self.data["world"]["per_robot"][str(rid)]

    def frames(self, rid: int | None = None):
        """The frames table as a pandas DataFrame (``frames_table``), or with ``rid`` that robot's counters.

        ``frames(rid)`` is ``frame_counts(rid)``, the older meaning, kept.
        """
        return self.frames_table() if rid is None else self.frame_counts(rid)

    def reports(self, behavior: str) -> dict[int, dict]:
        """Robot id -> that behaviour's report (robots without it are left out)."""
        return {rid: r[behavior] for rid, r in self.robots.items() if isinstance(r.get(behavior), dict)}

    @property
    def checks(self) -> list[dict]:
        return self.data.get("checks", [])

    @property
    def passed(self) -> bool:
        """Every check passed; False for an interrupted run, whose checks did not run."""
        return not self.data.get("interrupted") and all(c["passed"] for c in self.checks)

    @property
    def exit_code(self) -> int:
        """The command line's exit code for this run (``swarmactors.exitcodes.run_exit``: 0, 1, 3 or 130)."""
        from swarmactors.exitcodes import run_exit

        return int(run_exit(self.data)[0])

    def verdicts(self) -> dict[str, bool]:
        """Check name -> passed; a check with several outcomes (one per chain, per robot, …) passes if all do."""
        out: dict[str, bool] = {}
        for c in self.checks:
            out[c["name"]] = out.get(c["name"], True) and bool(c["passed"])
        return out

    def check(self, name: str) -> dict:
        for c in self.checks:
            if c["name"] == name:
                return c
        raise KeyError(f"no check {name!r} in this result (have {[c['name'] for c in self.checks]})")

    @property
    def trace_path(self) -> Path | None:
        name = self.data.get("trace")
        if not name or self.path is None:
            return None
        return self.path.parent / name

    @cached_property
    def trace(self) -> list[dict]:
        """Every tick record of the trace as Python objects, read once and kept: O(ticks) memory.

        For interactive use on small runs; nothing that runs after a run (checks, charts, plots, replay,
        export) reads it: they stream with ``records()``.
        """
        from swarmactors.oracle.trace import read_trace

        if self.trace_path is None:
            raise FileNotFoundError("this run wrote no trace (run.trace = false?)")
        return read_trace(self.trace_path)[1]

    def records(self) -> Iterator[dict]:
        """The tick records one at a time: streamed from the file unless ``trace`` was read already.

        What needs one tick or a running summary reads through this, so its memory is O(N), not O(ticks).
        """
        if "trace" in self.__dict__:
            yield from self.__dict__["trace"]
            return
        from swarmactors.oracle.trace import iter_trace

        if self.trace_path is None:
            raise FileNotFoundError("this run wrote no trace (run.trace = false?)")
        header = True
        ticks = []
        for obj in iter_trace(self.trace_path):
            if header:
                header = False
            elif not obj.get("end"):
                ticks.append(obj["t"])
                yield obj
        self.__dict__.setdefault("_ticks", np.asarray(ticks, dtype=np.int64))  # a whole pass: its ticks, kept

    def ticks(self) -> np.ndarray:
        """The ticks of the trace's records, in order, as an array (one streamed pass, then kept: 8 bytes a tick)."""
        if "_ticks" not in self.__dict__:
            self.__dict__["_ticks"] = np.fromiter((rec["t"] for rec in self.records()), dtype=np.int64)
        return self.__dict__["_ticks"]

    def last_tick(self) -> int:
        """The trace's last tick."""
        ticks = self.ticks()
        if not len(ticks):
            raise KeyError("the trace has no tick")
        return int(ticks[-1])

    def first_tick(self, at: int | None = None) -> int:
        """The first tick of the trace (at or after ``at`` when given)."""
        ticks = self.ticks()
        later = ticks if at is None else ticks[ticks >= at]
        if not len(later):
            raise KeyError(f"the trace has no tick at or after {at}")
        return int(later[0])

    def states(self) -> Iterator[tuple[dict, Severed]]:
        """Each tick record with the cuts and partition groups in force at it, in one streamed pass.

        ``graph_at(rec["t"], rec=rec, severed=severed)`` then builds the tick's graph without reading again.
        """
        links = Severed()
        for rec in self.records():
            links = links.after(rec)
            yield rec, links

    def first_record(self) -> dict:
        """The trace's first tick record (reads no further)."""
        records = self.records()
        try:
            return next(records)
        except StopIteration:
            raise KeyError("the trace has no tick") from None
        finally:
            records.close()

    def last_record(self) -> dict:
        """The trace's last tick record (streamed: only one record held at a time)."""
        last = None
        for last in self.records():  # noqa: B007 — the loop keeps the last one
            pass
        if last is None:
            raise KeyError("the trace has no tick")
        return last

    def record(self, tick: int) -> dict:
        for rec in self.records():
            if rec["t"] == tick:
                return rec
        raise KeyError(f"no tick {tick} in the trace")

    def ranges(self) -> dict[int, float]:
        """Each robot's radio range (robots added during the run included)."""
        return {rid: r["range"] for rid, r in self.robots.items()}

    def severed_at(self, tick: int) -> Severed:
        """Cut links and partition groups in force at ``tick``, replayed from the trace's events."""
        links = Severed()
        for rec in self.records():
            if rec["t"] > tick:
                break
            links = links.after(rec)
        return links

    def last_state(self) -> tuple[dict, Severed]:
        """The last tick record and the cuts and partition groups in force at it, in one streamed pass."""
        links = Severed()
        last = None
        for last in self.records():  # noqa: B007 — the loop keeps the last one
            links = links.after(last)
        if last is None:
            raise KeyError("the trace has no tick")
        return last, links

    def graph_at(self, tick: int, directed: bool = False, rec: dict | None = None,
                 severed: Severed | None = None) -> nx.Graph:
        """The true radio graph at ``tick``.

        Alive robots, links in range (mutual unless ``directed``: an edge a -> b when b is within a's range),
        minus cut links, links between partition groups and (``radio.occlusion``) links that cross an obstacle
        (swarmactors/oracle/occlusion_oracle.py, with shapely). An oracle: computed here from the trace, on its
        own (a k-d tree for candidate pairs, then the rule on exact distances), independently of the world's
        radio; tests/unit/test_graph_at.py checks that the two agree.
        """
        import networkx as nx
        from scipy.spatial import cKDTree

        rec = self.record(tick) if rec is None else rec  # ``rec``, ``severed``: when the caller has them
        links = self.severed_at(tick) if severed is None else severed  # the oracle's own replay (Severed)
        ranges = self.ranges()
        ids = [row[0] for row in rec.get("pos", [])]
        pos = np.array([row[1:] for row in rec.get("pos", [])], dtype=float)
        g = nx.DiGraph() if directed else nx.Graph()
        g.add_nodes_from(ids)
        if len(ids) < 2:
            return g
        r = np.array([ranges[i] for i in ids], dtype=float)
        # candidates with a margin, so that the tree's own rounding at the range's edge loses no pair
        pairs = cKDTree(pos).query_pairs(float(r.max()) * (1 + 1e-9) + 1e-12, output_type="ndarray")
        edges = []
        if links and len(pairs):
            pairs = pairs[[not links.between(ids[a], ids[b]) for a, b in pairs.tolist()]]
        for a, b in sorted(map(tuple, pairs.tolist())):
            d = np.linalg.norm(pos[b] - pos[a])
            if directed:
                edges += [(a, b)] * bool(d <= r[a]) + [(b, a)] * bool(d <= r[b])
            elif d <= r[a] and d <= r[b]:
                edges.append((a, b))
        sc = self.data.get("scenario") or {}
        if sc.get("radio", {}).get("occlusion"):
            from swarmactors.oracle.occlusion_oracle import Occluders

            world = sc["world"]
            if world.get("obstacles") or world.get("map"):
                occluders = Occluders(world)
                edges = [(a, b) for a, b in edges if not occluders.blocks(pos[a], pos[b])]
        g.add_edges_from((ids[a], ids[b]) for a, b in sorted(edges))
        return g

    def final_graph(self, directed: bool = False) -> nx.Graph:
        """The true radio graph at the last tick of the trace (``graph_at`` of that tick)."""
        return self.graph_at(self.last_record()["t"], directed)

    def poses_table(self):
        """The export's ``poses`` table as a pandas DataFrame (needs pandas): a row per tick and alive robot."""
        return table_frame("poses", self["scenario"], self._records_or_refuse())

    def frames_table(self):
        """The export's ``frames`` table as a pandas DataFrame (needs pandas): every frame sent, delivered, dropped."""
        return table_frame("frames", self["scenario"], self._records_or_refuse())

    def _records_or_refuse(self):
        if self.trace_path is None:
            raise ValueError("this run has no trace (run.trace = false?): no tables")
        return self.records

    poses = poses_table  # the names of the first release, kept
    frame_log = frames_table


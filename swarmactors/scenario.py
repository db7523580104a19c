"""Scenario files (TOML): loading, overrides, validation, resolution.

Every key is checked before anything starts: an unknown key, a wrong type or an
out-of-range value raises ``ScenarioError`` naming the file and the key.
Resolution fills defaults and turns placement rules into explicit positions
(from the run's seed), so the resolved scenario stored in result.json is a
complete description of the run.
"""

from __future__ import annotations

import copy
import inspect
import math
import re
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from swarmactors.behavior import is_num, params_problem
from swarmactors.plugins import BEHAVIORS, CHECKS, PluginError, resolve
from swarmactors.suggest import did_you_mean
from transport.messages import ACTIONS, action_problem

if TYPE_CHECKING:  # networkx and scipy are imported where used: a robot host imports this module and neither
    import networkx as nx


class ScenarioError(ValueError):
    """A scenario that cannot run; the message names the file and the key."""

    def __init__(self, source: str, key: str, message: str):
        super().__init__(f"{source}: {key}: {message}")
        self.source, self.key = source, key


# Each field: (type(s), default, check) where check(value) returns an error text or None.
def _positive(v):
    return None if v > 0 else "must be > 0"


def _non_negative(v):
    return None if v >= 0 else "must be >= 0"


def _probability(v):
    return None if 0.0 <= v <= 1.0 else "must be in [0, 1]"


def _one_of(*options):
    return lambda v: None if v in options else f"must be one of {', '.join(map(repr, options))}"


def _value_or_range(limit: float | None = None, unit: str = ""):
    """A number, or ``[lo, hi]`` with lo <= hi (drawn per robot from the run's seed); each within +-limit."""

    def check(v):
        vals = v if isinstance(v, list) else [v]
        if isinstance(v, list) and (len(v) != 2 or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                         for x in v)):
            return "must be a number or a range [lo, hi] of two numbers"
        if not all(math.isfinite(x) for x in vals):
            return "must be finite"
        if isinstance(v, list) and v[0] > v[1]:
            return "is a range [lo, hi] with lo > hi"
        if limit is not None and any(abs(x) > limit for x in vals):
            return f"must be within +-{limit:g}{unit}"
        return None

    return check


_NUM = (int, float)
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}")  # a run name is a directory name: no separators, no parent
_NAME_RULE = "must be 1 to 64 letters, digits, '.', '_' or '-', starting with a letter or digit (it names a directory)"
_NUM_OR_RANGE = (int, float, list)
MAX_DRIFT_PPM = 1e5  # |clock_drift| (swarmactors/robot_clock.py)

SCHEMA: dict[str, dict[str, tuple]] = {
    "run": {
        "name": (str, "run", lambda v: None if _NAME.fullmatch(v) else _NAME_RULE),
        "seed": (int, 0, _non_negative),
        "clock": (str, "lockstep", _one_of("lockstep", "realtime")),
        "ticks": (int, None, _positive),
        "duration": (_NUM, None, _positive),
        "dt": (_NUM, 1.0, _positive),
        "watchdog_s": (_NUM, 10.0, _positive),
        "join_timeout_s": (_NUM, 60.0, _positive),
        "state_every": (int, 1, _non_negative),
        # true = "full", false = "off"; "summary" leaves out the per-delivery rows (docs/trace.md)
        "trace": ((bool, str), True, lambda v: None if isinstance(v, bool) else _one_of("off", "summary", "full")(v)),
        "trace_compression": (str, "none", _one_of("none", "zstd")),  # trace.msgpack through Zstandard
        "processes": (int, 0, _non_negative),
        "trace_commands": (bool, False, None),  # tick records carry commanded velocities ("cmd", docs/trace.md)
    },
    "radio": {
        "range": (_NUM, 1.0, _positive),
        "latency": (int, 1, lambda v: None if v >= 1 else "must be >= 1 tick"),
        "latency_s": (_NUM, 0.01, _positive),
        "latency_min_s": (_NUM, None, _non_negative),
        "loss": (_NUM, 0.0, _probability),
        "model": (str, "bernoulli", _one_of("bernoulli", "distance")),
        "delta": (_NUM, 0.1, _positive),
        "bandwidth": (int, 0, _non_negative),
        "occlusion": (bool, False, None),  # obstacles block links (world/space.py)
        # bursty loss (world/bursts.py): "gilbert" replaces the Bernoulli ``loss``; ``model`` stays the distance model
        "loss_model": (str, "bernoulli", _one_of("bernoulli", "gilbert")),
        "p_gb": (_NUM, None, _probability),
        "p_bg": (_NUM, None, _probability),
        "loss_good": (_NUM, None, _probability),
        "loss_bad": (_NUM, None, _probability),
        "rab": (bool, False, None),  # every delivered frame carries its range and bearing (frame.rab)
        # excluded robots' copies of a broadcast are carried and recorded as overheard, or ("filter") not sent
        "exclude": (str, "overheard", _one_of("overheard", "filter")),
    },
    "world": {
        "dims": (int, 2, _one_of(2, 3)),
        # robots a run may hold, joins and adds included (issue 27)
        "max_robots": (int, 10_000, lambda v: None if 1 <= v <= MAX_ROBOTS_LIMIT else
                       f"must be in 1..{MAX_ROBOTS_LIMIT}"),
        "bounds": (list, None, None),
        "objects": (list, [], None),
        "obstacles": (list, [], None),  # convex prisms (swarmactors/maps.py, transport/space.py)
        "map": ((dict, str), None, None),  # a grid map: a Moving AI file or a generated maze
        "blocking": (bool, False, None),  # bodies cannot overlap (world/space.py)
    },
}
GROUP: dict[str, tuple] = {
    "count": (int, None, _positive),
    "positions": (list, None, None),
    "placement": (str, "uniform", _one_of("uniform", "grid", "line", "ring")),
    "area": (list, None, None),
    "connected": (bool, False, None),
    "spacing": (_NUM, None, _positive),
    "range": (_NUM, None, _positive),
    "sensing": (_NUM, None, _positive),
    "speed": (_NUM, None, _positive),  # length units per second; none = unlimited
    "turn_rate": (_NUM, None, _positive),  # rad per second; none = holonomic
    "noise": (_NUM, 0.0, _non_negative),
    "heading": (_NUM, 0.0, None),
    "kind": (str, "ground", _one_of("ground", "flying")),
    "body_radius": (_NUM, 0.0, _non_negative),  # 0: a point
    "altitude": (list, None, None),  # [min, max] of a flying robot's z in a 3-D world
    "climb_rate": (_NUM, None, _positive),  # vertical speed cap of a flying robot (default: its speed)
    "knows_map": (bool, False, None),  # ctx.map: the static map as prior knowledge
    "obstacle_rays": (int, 0, _non_negative),  # ctx.rays: this many range rays to obstacles
    "behaviors": (list, [], None),
    # situated sensing and clocks (world/situated.py, swarmactors/robot_clock.py)
    "sensing_frame": (str, "global", _one_of("global", "local")),
    "range_noise": (_NUM, 0.0, _non_negative),
    "bearing_noise": (_NUM, 0.0, _non_negative),
    "heading_offset": (_NUM_OR_RANGE, None, _value_or_range()),
    "sensing_to": (str, "center", _one_of("center", "surface")),  # "surface": to the closest point of a body
    "clock_offset": (_NUM_OR_RANGE, 0.0, _value_or_range()),
    "clock_drift": (_NUM_OR_RANGE, 0.0, _value_or_range(MAX_DRIFT_PPM, " ppm")),
}
SITUATED_DEFAULTS = {k: GROUP[k][1] for k in ("sensing_frame", "range_noise", "bearing_noise", "heading_offset",
                                              "sensing_to", "clock_offset", "clock_drift")}
EVENT_ACTIONS = tuple(ACTIONS)  # one list of world actions: transport/messages.py
MAX_FILE_BYTES = 16 * 1024 * 1024  # a scenario file larger than this is refused before it is parsed
MAX_ROBOTS_LIMIT = 1_000_000  # the largest world.max_robots a scenario may ask for


def load(path: str | Path, overrides: list[str] = ()) -> dict:
    """Read, override, validate and resolve the scenario file at ``path``."""
    return resolve_scenario(read_raw(path), str(path), overrides)


def read_raw(path: str | Path) -> dict:
    """The scenario file at ``path`` as parsed TOML (``ScenarioError`` naming the file)."""
    p = Path(path)
    try:
        size = p.stat().st_size
        if size > MAX_FILE_BYTES:
            raise ScenarioError(str(path), "file", f"{size} bytes: larger than the {MAX_FILE_BYTES} a scenario may be")
        return tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ScenarioError(str(path), "file", "no such file") from None
    except IsADirectoryError:
        raise ScenarioError(str(path), "file", "is a directory, not a scenario file") from None
    except UnicodeDecodeError as exc:
        raise ScenarioError(str(path), "file", f"not UTF-8 text (byte {exc.start}: {exc.reason})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(str(path), "syntax", str(exc)) from None
    except RecursionError:
        raise ScenarioError(str(path), "syntax", "arrays or tables nested too deeply") from None


def resolve_scenario(raw: dict, source: str = "<scenario>", overrides: list[str] = ()) -> dict:
    """Validate and resolve a scenario given as a dict (as parsed from TOML)."""
    raw = copy.deepcopy(raw)
    for item in overrides:
        apply_override(raw, item, source)
    known = {"run", "radio", "world", "robots", "events", "checks"}
    for key in raw:
        if key not in known:
            raise ScenarioError(source, key, f"unknown section (expected one of {', '.join(sorted(known))})"
                                             + did_you_mean(key, known))
    out: dict[str, Any] = {}
    for section, schema in SCHEMA.items():
        table = raw.get(section, {})
        if not isinstance(table, dict):
            raise ScenarioError(source, section, "must be a table")
        out[section] = _fields(table, schema, source, section)
    run = out["run"]
    if run["ticks"] is None:
        if run["duration"] is None:
            raise ScenarioError(source, "run.ticks", "give run.ticks (or run.duration in seconds)")
        run["ticks"] = max(1, int(round(run["duration"] / run["dt"])))
    radio = out["radio"]
    if radio["latency_min_s"] is not None and radio["latency_min_s"] > radio["latency_s"]:
        raise ScenarioError(source, "radio.latency_min_s", "must not exceed radio.latency_s")
    _check_bursts(radio, source)
    _check_world(out["world"], source)
    _check_space(out["world"], source)
    groups = raw.get("robots")
    if not isinstance(groups, list) or not groups:
        raise ScenarioError(source, "robots", "give at least one [[robots]] group")
    _check_sizes(groups, raw.get("events", []), out["world"]["max_robots"], source)
    rng = np.random.default_rng([run["seed"], 0x5CE7])
    out["robots"] = [_group(g, f"robots[{i}]", out, source, rng) for i, g in enumerate(groups)]
    _connect_groups(out, source, rng)
    out["events"] = [_event(e, f"events[{i}]", out, source, rng) for i, e in enumerate(raw.get("events", []))]
    _check_event_ids(out, source)
    out["checks"] = [_check(c, f"checks[{i}]", source) for i, c in enumerate(raw.get("checks", []))]
    out["source"] = source
    return out


def _check_bursts(radio: dict, source: str) -> None:
    """Gilbert-Elliott keys: p_gb and p_bg with ``loss_model = "gilbert"`` (which replaces ``loss``), only then."""
    keys = ("p_gb", "p_bg", "loss_good", "loss_bad")
    if radio["loss_model"] != "gilbert":
        for key in keys:
            if radio[key] is not None:
                raise ScenarioError(source, f"radio.{key}",
                                    'is a Gilbert-Elliott parameter: set radio.loss_model = "gilbert"')
        return
    for key in ("p_gb", "p_bg"):
        if radio[key] is None:
            raise ScenarioError(source, f"radio.{key}", 'give it (a probability per tick) with loss_model = "gilbert"')
    if radio["loss"]:
        raise ScenarioError(source, "radio.loss", 'must be 0 with loss_model = "gilbert" (its bursts replace it)')
    radio["loss_good"] = 0.0 if radio["loss_good"] is None else radio["loss_good"]
    radio["loss_bad"] = 1.0 if radio["loss_bad"] is None else radio["loss_bad"]


def apply_override(raw: dict, item: str, source: str = "--set") -> None:
    """Apply ``SECTION.KEY=VALUE`` (list items by index, e.g. ``robots.0.count=50``)."""
    path, sep, text = item.partition("=")
    if not sep or not path:
        raise ScenarioError(source, item, "an override must look like section.key=value")
    try:
        value = tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        value = text
    set_value(raw, path, value, source)


def set_value(raw: dict, path: str, value: Any, source: str = "--set") -> None:
    """Set the value at dotted ``path`` (list items by index) in a raw scenario."""
    parts = path.split(".")
    node: Any = raw
    for i, part in enumerate(parts[:-1]):
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise ScenarioError(source, path, f"no item {part!r} in {'.'.join(parts[:i]) or 'the scenario'}")
            node = node[int(part)]
        elif isinstance(node, dict):
            node = node.setdefault(part, {})
        else:
            raise ScenarioError(source, path, f"{'.'.join(parts[:i]) or 'the scenario'} is a value, not a table")
    last = parts[-1]
    if isinstance(node, list):
        if not last.isdigit() or int(last) >= len(node):
            raise ScenarioError(source, path, f"no item {last!r}")
        node[int(last)] = value
    elif isinstance(node, dict):
        node[last] = value
    else:
        raise ScenarioError(source, path, "cannot set a key inside a value")


def _fields(table: dict, schema: dict, source: str, where: str) -> dict:
    out = {}
    for key in table:
        if key not in schema:
            raise ScenarioError(source, f"{where}.{key}", f"unknown key (known: {', '.join(sorted(schema))})"
                                + did_you_mean(key, schema))
    for key, (typ, default, check) in schema.items():
        if key not in table:
            out[key] = copy.deepcopy(default)
            continue
        value = table[key]
        types = typ if isinstance(typ, tuple) else (typ,)
        if isinstance(value, bool) and bool not in types or not isinstance(value, types):
            raise ScenarioError(
                source, f"{where}.{key}",
                f"{value!r} is a {type(value).__name__}, expected {' or '.join(t.__name__ for t in types)}",
            )
        if isinstance(value, float) and not math.isfinite(value):
            raise ScenarioError(source, f"{where}.{key}", f"{value!r} is not a finite number")
        if check is not None:
            problem = check(value)
            if problem:
                raise ScenarioError(source, f"{where}.{key}", f"{value!r} {problem}")
        out[key] = value
    return out


def _points(value: Any, dims: int, source: str, key: str, count: int | None = None) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ScenarioError(source, key, "must be a list of coordinate lists") from None
    if arr.ndim != 2 or arr.shape[1] not in (2, dims) or (count is not None and len(arr) != count):
        raise ScenarioError(source, key, f"must be a list of {count or 'N'} points with {dims} coordinates")
    if not np.all(np.isfinite(arr)):
        raise ScenarioError(source, key, "coordinates must be finite")
    if arr.shape[1] < dims:
        arr = np.hstack([arr, np.zeros((len(arr), dims - arr.shape[1]))])
    return arr


def _check_world(world: dict, source: str) -> None:
    dims = world["dims"]
    if world["bounds"] is not None:
        b = _points(world["bounds"], dims, source, "world.bounds", 2)
        if np.any(b[0][:2] >= b[1][:2]) or np.any(b[0][2:] > b[1][2:]):
            raise ScenarioError(source, "world.bounds", "must be [[min...], [max...]] with min < max "
                                "(z: min <= max)")
        world["bounds"] = b.tolist()
    names = set()
    for i, obj in enumerate(world["objects"]):
        key = f"world.objects[{i}]"
        if (not isinstance(obj, dict) or not {"name", "pos"} <= set(obj) <= {"name", "pos", "known_by"}
                or not isinstance(obj["name"], str)):
            raise ScenarioError(source, key, "must be {name = \"...\", pos = [x, y]} (and optionally known_by)")
        known = obj.get("known_by", "all")
        if not (known in ("all", "sensing") or (isinstance(known, list) and all(
                type(i) is int and i >= 0 for i in known))):
            raise ScenarioError(source, f"{key}.known_by",
                                f"{known!r} must be \"all\", \"sensing\" or a list of robot ids")
        if obj["name"] in names:
            raise ScenarioError(source, key, f"duplicate object name {obj['name']!r}")
        names.add(obj["name"])
        obj["pos"] = _points([obj["pos"]], dims, source, f"{key}.pos", 1)[0].tolist()


def _check_sizes(groups: list, events: Any, limit: int, source: str) -> None:
    """Robot counts (groups, then ``add`` events) stay within ``world.max_robots``, checked before allocating.

    A scenario asking for 10**9 robots is refused at once, naming the key.
    """
    total = 0
    items = [(f"robots[{i}]", g) for i, g in enumerate(groups)]
    if isinstance(events, list):
        items += [(f"events[{i}].add", e["add"]) for i, e in enumerate(events) if isinstance(e, dict)
                  and isinstance(e.get("add"), dict)]
    for where, g in items:
        if not isinstance(g, dict):
            continue
        n = g.get("count")
        if n is None and isinstance(g.get("positions"), list):
            n = len(g["positions"])
        if not isinstance(n, int) or isinstance(n, bool):
            continue  # the group's own validation names the problem
        total += max(n, 0)
        if total > limit:
            key = f"{where}.count" if "count" in g else f"{where}.positions"
            raise ScenarioError(source, key, f"{n} robots bring the run to {total}, above world.max_robots = {limit}")


def _check_space(world: dict, source: str) -> None:
    """Resolve ``world.obstacles`` (convex prisms, boxes, C shapes) and ``world.map`` (a file or a maze)."""
    from swarmactors import maps
    from transport.space import convex

    resolved = []
    for i, ob in enumerate(world["obstacles"]):
        key = f"world.obstacles[{i}]"
        if not isinstance(ob, dict):
            raise ScenarioError(source, key, 'must be a table: {xy = [[x, y], ...]}, {box = [[x0, y0], [x1, y1]]} '
                                             'or {c_shape = {center, size, thickness, opening}}, with z = [lo, hi]')
        unknown = set(ob) - {"xy", "box", "c_shape", "z"}
        if unknown or sum(k in ob for k in ("xy", "box", "c_shape")) != 1:
            raise ScenarioError(source, key, "give exactly one of xy, box or c_shape (and optionally z)"
                                + (f"; unknown key(s) {', '.join(sorted(unknown))}" if unknown else ""))
        z = _extent(ob.get("z"), source, f"{key}.z")
        if "c_shape" in ob:
            c = ob["c_shape"]
            if (not isinstance(c, dict) or set(c) - {"center", "size", "thickness", "opening"}
                    or not {"center", "size", "thickness"} <= set(c) or c.get("opening", "+x") not in
                    ("+x", "-x", "+y", "-y") or not all(is_num(c[k]) and c[k] > 0 for k in ("size", "thickness"))
                    or c["thickness"] * 2 >= c["size"]):
                raise ScenarioError(source, f"{key}.c_shape", "must be {center = [x, y], size = S, thickness = T "
                                    "(0 < 2T < S), opening = \"+x\"|\"-x\"|\"+y\"|\"-y\"}")
            center = _points([c["center"]], 2, source, f"{key}.c_shape.center", 1)[0].tolist()
            resolved += maps.c_shape(center, float(c["size"]), float(c["thickness"]), c.get("opening", "+x"), z)
            continue
        if "box" in ob:
            b = _points(ob["box"], 2, source, f"{key}.box", 2)
            if np.any(b[0][:2] >= b[1][:2]):
                raise ScenarioError(source, f"{key}.box", "must be [[x_min, y_min], [x_max, y_max]] with min < max")
            resolved.append(maps.box(b[0].tolist(), b[1].tolist(), z))
            continue
        xy = ob["xy"]
        if not isinstance(xy, list) or len(xy) < 3:
            raise ScenarioError(source, f"{key}.xy", f"a polygon needs at least 3 vertices, got "
                                f"{len(xy) if isinstance(xy, list) else xy!r}")
        pts = _points(xy, 2, source, f"{key}.xy")[:, :2]
        if not convex(pts):
            raise ScenarioError(source, f"{key}.xy", "must be a convex polygon with non-zero area, vertices in "
                                "order (split a non-convex obstacle into convex pieces)")
        resolved.append({"xy": pts.tolist(), "z": z})
    world["obstacles"] = resolved
    m = world["map"]
    if m is None:
        return
    if isinstance(m, str):
        m = {"file": m}
    known = {"file", "maze", "cell", "origin", "tree_height"}
    if set(m) - known or ("file" in m) == ("maze" in m):
        raise ScenarioError(source, "world.map", "must be a file name, or a table with exactly one of file or "
                            f"maze (and cell, origin, tree_height); known keys: {', '.join(sorted(known))}")
    cell = m.get("cell", 1.0)
    if not is_num(cell) or cell <= 0:
        raise ScenarioError(source, "world.map.cell", f"{cell!r} must be a positive number (length units per cell)")
    origin = _points([m.get("origin", [0.0, 0.0])], 2, source, "world.map.origin", 1)[0][:2].tolist()
    tree = m.get("tree_height")
    if tree is not None and (not is_num(tree) or tree <= 0):
        raise ScenarioError(source, "world.map.tree_height", f"{tree!r} must be a positive number")
    if "file" in m:
        path = Path(m["file"])
        if not path.is_absolute() and source not in ("<scenario>", "--set"):
            path = Path(source).parent / path
        try:
            world["map"] = maps.read_map(path, tree_height=tree, cell=float(cell), origin=origin)
        except maps.MapError as exc:
            raise ScenarioError(source, "world.map.file", str(exc)) from None
        return
    mz = m["maze"]
    mkeys = {"cols", "rows", "seed", "corridor", "wall"}
    if (not isinstance(mz, dict) or set(mz) - mkeys or not {"cols", "rows"} <= set(mz)
            or not all(type(mz.get(k, 1)) is int and mz.get(k, 1) >= 1 for k in mkeys - {"seed"})):
        raise ScenarioError(source, "world.map.maze", "must be {cols = C, rows = R} with positive integers "
                            "(and seed, corridor = cells per corridor, wall = cells per wall)")
    try:
        rows = maps.maze(mz["cols"], mz["rows"], int(mz.get("seed", 0)), mz.get("corridor", 2), mz.get("wall", 1))
    except maps.MapError as exc:  # more cells than maps.MAX_MAP_CELLS
        raise ScenarioError(source, "world.map.maze", exc.message) from None
    world["map"] = maps.parse_map(["type octile", f"height {len(rows)}", f"width {len(rows[0])}", "map", *rows],
                                  "maze", tree_height=tree, cell=float(cell), origin=origin)


def _extent(z: Any, source: str, key: str) -> list | None:
    """A vertical extent [lo, hi] (lo < hi) or None (every height)."""
    if z is None:
        return None
    if not (isinstance(z, list) and len(z) == 2 and all(is_num(v) for v in z) and z[0] < z[1]):
        raise ScenarioError(source, key, f"{z!r} must be [z_min, z_max] with z_min < z_max")
    return [float(z[0]), float(z[1])]


def _group(g: Any, where: str, sc: dict, source: str, rng: np.random.Generator) -> dict:
    if not isinstance(g, dict):
        raise ScenarioError(source, where, "must be a table")
    grp = _fields(g, GROUP, source, where)
    dims = sc["world"]["dims"]
    grp["range"] = grp["range"] if grp["range"] is not None else sc["radio"]["range"]
    grp["sensing"] = grp["sensing"] if grp["sensing"] is not None else grp["range"]
    if grp["heading_offset"] is not None and grp["sensing_frame"] != "local":
        raise ScenarioError(source, f"{where}.heading_offset", 'applies only with sensing_frame = "local"')
    if (grp["count"] is None) == (grp["positions"] is None):
        raise ScenarioError(source, where, "give exactly one of count or positions")
    if grp["positions"] is not None:
        grp["positions"] = _points(grp["positions"], dims, source, f"{where}.positions").tolist()
        grp["count"] = len(grp["positions"])
        grp["placement"] = "explicit"
    else:
        grp["positions"] = _place(grp, sc, source, where, rng).tolist()
    _check_body(grp, sc, source, where)
    grp["behaviors"] = [_behavior(b, f"{where}.behaviors[{i}]", source, grp) for i, b in enumerate(grp["behaviors"])]
    return grp


def _check_body(grp: dict, sc: dict, source: str, where: str) -> None:
    """Altitude limits of flying robots; ground robots at z = 0 in 3-D; no robot inside an obstacle."""
    dims = sc["world"]["dims"]
    alt = grp["altitude"]
    if alt is not None:
        if not (isinstance(alt, list) and len(alt) == 2 and all(is_num(v) for v in alt) and 0 <= alt[0] <= alt[1]):
            raise ScenarioError(source, f"{where}.altitude", f"{alt!r} must be [min, max] with 0 <= min <= max")
        if dims != 3 or grp["kind"] != "flying":
            raise ScenarioError(source, f"{where}.altitude", "applies to flying robots in a 3-D world (world.dims = 3)")
    if dims == 3:
        pts = np.array(grp["positions"], dtype=float)
        if grp["kind"] == "ground":
            high = np.flatnonzero(pts[:, 2] != 0.0)
            if grp["placement"] == "explicit" and high.size:
                raise ScenarioError(source, f"{where}.positions[{high[0]}]", f"a ground robot stays at z = 0, not "
                                    f"{pts[high[0], 2]:g} (give the group kind = \"flying\" to fly)")
            pts[:, 2] = 0.0
        elif alt is not None:
            bad = np.flatnonzero((pts[:, 2] < alt[0]) | (pts[:, 2] > alt[1]))
            if bad.size:
                raise ScenarioError(source, f"{where}.positions[{bad[0]}]",
                                    f"altitude {pts[bad[0], 2]:g} is outside {where}.altitude = {alt}")
        grp["positions"] = pts.tolist()
    space = _space_of(sc)
    if space is None or (dims == 2 and grp["kind"] == "flying"):
        return
    inside = np.flatnonzero(space.inside(_as3d(grp["positions"]), ground=grp["kind"] == "ground"))
    if inside.size:
        p = grp["positions"][inside[0]]
        raise ScenarioError(source, f"{where}.positions[{inside[0]}]",
                            f"robot at {[round(v, 6) for v in p]} is inside an obstacle"
                            + ("" if grp["placement"] == "explicit" else f" ({grp['placement']} placement)"))


def _space_of(sc: dict):
    """The run's obstacles as a ``transport.space.Space`` (None when there are none)."""
    w = sc["world"]
    if not w.get("obstacles") and not w.get("map"):
        return None
    from transport.space import space_from_spec

    return space_from_spec(w)


def _as3d(positions) -> np.ndarray:
    p = np.asarray(positions, dtype=float)
    return p if p.shape[1] == 3 else np.column_stack([p, np.zeros(len(p))])


def _area(grp: dict, sc: dict, source: str, where: str) -> np.ndarray:
    dims = sc["world"]["dims"]
    if grp["area"] is not None:
        area = _points(grp["area"], dims, source, f"{where}.area", 2)
    elif sc["world"]["bounds"] is not None:
        area = np.array(sc["world"]["bounds"])
    else:
        side = math.sqrt(grp["count"]) * grp["range"] * 0.6
        area = np.array([[0.0] * dims, [side, side] + [0.0] * (dims - 2)])
    return area


def _place(grp: dict, sc: dict, source: str, where: str, rng: np.random.Generator) -> np.ndarray:
    n, rule = grp["count"], grp["placement"]
    area = _area(grp, sc, source, where)
    lo, hi = area[0], area[1]
    dims = len(lo)
    if rule == "uniform":
        pts = lo + rng.random((n, dims)) * (hi - lo)
        space = _space_of(sc)
        if space is not None and not (dims == 2 and grp["kind"] == "flying"):
            for _ in range(1000):  # redraw the robots that fell inside an obstacle
                inside = np.flatnonzero(space.inside(_as3d(pts) * ([1, 1, 0] if grp["kind"] == "ground" else 1),
                                                     ground=grp["kind"] == "ground"))
                if inside.size == 0:
                    break
                pts[inside] = lo + rng.random((inside.size, dims)) * (hi - lo)
        return pts
    spacing = grp["spacing"] if grp["spacing"] is not None else grp["range"] * 0.9
    pts = np.zeros((n, dims))
    if rule == "grid":
        cols = math.ceil(math.sqrt(n))
        for i in range(n):
            pts[i, :2] = lo[:2] + spacing * np.array([i % cols, i // cols])
    elif rule == "line":
        pts[:, 0] = lo[0] + spacing * np.arange(n)
        pts[:, 1] = lo[1]
    elif rule == "ring":
        # chord between neighbours on the circle equals the spacing
        radius = spacing / (2 * math.sin(math.pi / n)) if n > 1 else 0.0
        ang = 2 * math.pi * np.arange(n) / n
        pts[:, 0] = lo[0] + radius * np.cos(ang)
        pts[:, 1] = lo[1] + radius * np.sin(ang)
    return pts


def _connect_groups(sc: dict, source: str, rng: np.random.Generator) -> None:
    """Redraw groups with ``connected = true`` until the whole swarm's graph is connected."""
    groups = sc["robots"]
    if not any(g["connected"] for g in groups):
        return
    ranges = np.concatenate([[g["range"]] * g["count"] for g in groups])
    draws = iter(range(2000))

    def draw() -> np.ndarray:
        if next(draws):  # the first draw is the placement already made
            for i, g in enumerate(groups):
                if g["connected"] and g["placement"] != "explicit":
                    g["positions"] = _place(g, sc, source, f"robots[{i}]", rng).tolist()
        return np.vstack([np.array(g["positions"]) for g in groups])

    try:
        draw_until_connected(draw, ranges, attempts=2000, space=occluding_space(sc))
    except ValueError:
        raise ScenarioError(
            source, "robots.connected", "no connected placement found in 2000 draws; enlarge range or shrink area"
        ) from None


def mutual_links(pos: np.ndarray, ranges: np.ndarray, space=None) -> list[tuple[int, int]]:
    """Pairs (a, b), a < b, each within the other's range, sorted: the world's own rule (``world.sensing.within``).

    The one "who is in range" of the product, shared by the radio, the charts and connected placements. With
    ``space`` (a ``transport.space.Space``, when ``radio.occlusion`` is on: ``occluding_space``), pairs whose
    link crosses an obstacle are left out, by the same geometry the radio uses.
    """
    from world.sensing import within

    pos = np.asarray(pos, dtype=float)
    if len(pos) < 2:
        return []
    reach = within(pos, np.arange(len(pos)), np.asarray(ranges, dtype=float))
    heard = {a: set(bs.tolist()) for a, bs in reach.items()}
    pairs = [(a, b) for a in range(len(pos)) for b in reach[a].tolist() if b > a and a in heard[b]]
    if space is not None and pairs:
        a, b = np.array(pairs).T
        pts = _as3d(pos)
        pairs = [p for p, hidden in zip(pairs, space.blocked(pts[a], pts[b], ground=False), strict=True) if not hidden]
    return pairs


def occluding_space(sc: dict):
    """The obstacles that block links in a resolved scenario (``radio.occlusion`` on), or None."""
    return _space_of(sc) if sc.get("radio", {}).get("occlusion") else None


def connected(pos: np.ndarray, ranges: np.ndarray, space=None) -> bool:
    """Whether the mutual links (``mutual_links``) connect every robot (no robot: False)."""
    n = len(pos)
    if n == 0:
        return False
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    parts = n
    for a, b in mutual_links(pos, ranges, space):
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[ra] = rb
            parts -= 1
    return parts == 1


def draw_until_connected(draw: Callable[[], np.ndarray], ranges: Any, attempts: int, space=None) -> np.ndarray:
    """Call ``draw()`` until the positions it returns are connected (``connected``); ValueError after ``attempts``.

    ``ranges``: one radio range for all, or one per robot; ``space``: obstacles that block links (or None).
    """
    for _ in range(attempts):
        pts = np.asarray(draw(), dtype=float)
        radii = np.broadcast_to(np.asarray(ranges, dtype=float), (len(pts),))
        if connected(pts, radii, space):
            return pts
    raise ValueError(f"no connected placement in {attempts} draws")


def undirected_graph(pos: np.ndarray, ranges: np.ndarray, ids: list[int] | None = None) -> nx.Graph:
    """Robots as nodes, an edge where each is within the other's range (the mutual links)."""
    import networkx as nx

    ids = list(range(len(pos))) if ids is None else ids
    g = nx.Graph()
    g.add_nodes_from(ids)
    g.add_edges_from((ids[a], ids[b]) for a, b in mutual_links(pos, ranges))
    return g


def _behavior(b: Any, where: str, source: str, group: dict | None = None) -> dict:
    """A behaviour spec.

    ``use`` (short name or module:Class), optional ``as`` (the name its report goes under; default the
    class's ``name``, else ``use``), then its parameters. A class's ``validate(params)`` checks them; one
    declared ``validate(params, group)`` also gets the robot group as resolved (its ``range``, ``sensing``,
    ``speed``...), for rules that tie a parameter to the robots it runs on.
    """
    if not isinstance(b, dict) or not isinstance(b.get("use"), str):
        raise ScenarioError(source, where, 'must be a table with use = "name" or "module:Class"')
    if "as" in b and not (isinstance(b["as"], str) and b["as"]):
        raise ScenarioError(source, f"{where}.as", f"{b['as']!r} must be a non-empty string")
    try:
        cls = resolve(BEHAVIORS, b["use"])
    except PluginError as exc:
        raise ScenarioError(source, f"{where}.use", str(exc)) from None
    params = {k: v for k, v in b.items() if k not in ("use", "as")}
    frame = (group or {}).get("sensing_frame", "global")
    if frame not in getattr(cls, "frames", ("global",)):
        raise ScenarioError(source, where, f"behaviour {b['use']!r} does not support sensing_frame = {frame!r} "
                                           f"(it supports {', '.join(getattr(cls, 'frames', ('global',)))})")
    problem = params_problem(cls, params, group or {})
    if problem:
        raise ScenarioError(source, where, f"{b['use']}: {problem}")
    return {"use": b["use"], "as": b.get("as") or getattr(cls, "name", "") or b["use"], **params}


def _event(e: Any, where: str, sc: dict, source: str, rng: np.random.Generator) -> dict:
    if not isinstance(e, dict) or "at" not in e:
        raise ScenarioError(source, where, "must be a table with at = <tick>")
    at = e["at"]
    if not isinstance(at, int) or isinstance(at, bool) or at < 0:
        raise ScenarioError(source, f"{where}.at", f"{at!r} is not a tick (an integer >= 0)")
    actions = [k for k in e if k != "at"]
    unknown = [k for k in actions if k not in EVENT_ACTIONS]
    if unknown:
        raise ScenarioError(source, f"{where}.{unknown[0]}", f"unknown event (known: {', '.join(EVENT_ACTIONS)})"
                            + did_you_mean(unknown[0], EVENT_ACTIONS))
    if len(actions) != 1:
        raise ScenarioError(source, where, "give exactly one action besides 'at'")
    action = actions[0]
    value = e[action]
    key = f"{where}.{action}"
    if action == "loss" and sc["radio"]["loss_model"] == "gilbert":
        raise ScenarioError(source, key, 'radio.loss_model is "gilbert": its bursts replace the Bernoulli loss')
    if action == "add":
        value = expand_group(_group(value, key, sc, source, rng))
    else:  # the world's own rule for the action (transport/messages.py); robot ids are checked later
        objects = {o["name"] for o in sc["world"]["objects"]}
        problem = action_problem({action: value}, dims=sc["world"]["dims"], objects=objects)
        if problem:
            raise ScenarioError(source, key, problem)
        if action == "kill" and isinstance(value, int):
            value = [value]
    return {"at": at, action: value}


def _check_event_ids(sc: dict, source: str) -> None:
    """Robot ids in events must exist when the event applies (robots added earlier count)."""
    count = sum(g["count"] for g in sc["robots"])
    order = sorted(range(len(sc["events"])), key=lambda i: sc["events"][i]["at"])
    for i in order:
        e = sc["events"][i]
        if "add" in e:
            count += len(e["add"])
        for action in ("kill", "cut", "restore", "partition"):
            ids = [x for item in e.get(action, []) for x in (item if isinstance(item, list) else [item])]
            bad = [x for x in ids if not 0 <= x < count]
            if bad:
                raise ScenarioError(source, f"events[{i}].{action}",
                                    f"no robot {bad[0]} at tick {e['at']} (ids 0..{count - 1} exist then)")


def _check(c: Any, where: str, source: str) -> dict:
    if not isinstance(c, dict) or not isinstance(c.get("use"), str):
        raise ScenarioError(source, where, 'must be a table with use = "family.check"')
    try:
        fn = resolve(CHECKS, c["use"])
    except PluginError as exc:
        raise ScenarioError(source, f"{where}.use", str(exc)) from None
    params = {k: v for k, v in c.items() if k != "use"}
    try:

        inspect.signature(fn).bind(None, **params)
    except TypeError as exc:
        raise ScenarioError(source, where, f"{c['use']}: {exc}") from None
    return dict(c)


def to_raw(sc: dict) -> dict:
    """A resolved scenario back in file form (explicit positions): running it reproduces the run."""
    raw: dict[str, Any] = {}
    for section in ("run", "radio", "world"):
        raw[section] = {k: v for k, v in sc[section].items() if v is not None and v != []}
    raw["run"].pop("duration", None)
    groups = []
    for g in sc["robots"]:
        groups.append({k: v for k, v in g.items()
                       if v is not None and k not in ("count", "placement", "area", "connected", "spacing")})
    raw["robots"] = groups
    events = []
    for e in sc["events"]:
        if "add" in e:
            specs = e["add"]
            common = {k: v for k, v in specs[0].items() if k != "pos"}
            events.append({"at": e["at"], "add": {"positions": [s["pos"] for s in specs], **common}})
        else:
            events.append(dict(e))
    if events:
        raw["events"] = events
    if sc["checks"]:
        raw["checks"] = [dict(c) for c in sc["checks"]]
    return raw


def expand_group(grp: dict) -> list[dict]:
    """Per-robot specs for the world from one resolved group."""
    fields = ("range", "sensing", "speed", "turn_rate", "noise", "heading", "kind", "body_radius", "altitude",
              "climb_rate", "knows_map", "obstacle_rays", "behaviors")
    common = {k: grp[k] for k in fields if grp[k] is not None}
    common |= {k: grp[k] for k, default in SITUATED_DEFAULTS.items() if grp.get(k, default) != default}
    return [{"pos": p, **common} for p in grp["positions"]]


def world_spec(sc: dict) -> dict:
    """The world's view of a resolved scenario: per-robot specs, no checks."""
    robots = [r for g in sc["robots"] for r in expand_group(g)]
    return {"run": sc["run"], "radio": sc["radio"], "world": sc["world"], "robots": robots, "events": sc["events"]}

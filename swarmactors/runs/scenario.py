"""Scenario files (TOML): loading, overrides and resolution; the scenario model is transport/scenario.py.

Every key is checked before anything starts: an unknown key, a wrong type, an out-of-range value or a broken rule
between keys raises ``ScenarioError`` naming the file and the key (``flooding.toml: radio.loss: 2 must be in
[0, 1]``); the types, defaults, limits and rules are the model's (``transport.scenario``). Resolution then places the
robots (from the run's seed), reads the map, and checks behaviours and checks against their classes, so the resolved
scenario stored in result.json is a complete description of the run.
"""

from __future__ import annotations

import contextlib
import copy
import inspect
import math
import re
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec
import numpy as np

from swarmactors.robot.behavior import params_problem
from swarmactors.robot.plugins import BEHAVIORS, CHECKS, PluginError
from swarmactors.robot.plugins import resolve as resolve_plugin
from transport.scenario import (
    UNSET,
    MapSource,
    Obstacle,
    Scenario,
    SpecError,
    World,
    decode,
    points,
    robot_spec,
    robot_specs,
)

if TYPE_CHECKING:  # networkx and scipy are imported where used: a robot host imports this module and neither
    import networkx as nx


class ScenarioError(ValueError):
    """A scenario that cannot run; the message names the file and the key."""

    def __init__(self, source: str, key: str, message: str):
        super().__init__(f"{source}: {key}: {message}")
        self.source, self.key = source, key


MAX_FILE_BYTES = 16 * 1024 * 1024  # a scenario file larger than this is refused before it is parsed
# A file with more commas than this (array items and inline-table keys) is refused before it is parsed: the parser
# takes about 10 s per million items, and no scenario needs so many (500,000 explicit 2-D positions would fit).
MAX_ITEMS = 1_000_000


@contextlib.contextmanager
def _naming(source: str):
    """Turn the model's ``SpecError`` (a key path and a rule) into a ``ScenarioError`` naming the file."""
    try:
        yield
    except SpecError as exc:
        raise ScenarioError(source, exc.key, exc.problem) from None


def load(path: str | Path, overrides: list[str] = ()) -> dict:
    """Read, override, validate and resolve the scenario file at ``path`` (its data: ``Scenario.to_dict``)."""
    return resolve_scenario(read_raw(path), str(path), overrides)


def read_raw(path: str | Path) -> dict:
    """The scenario file at ``path`` as parsed TOML (``ScenarioError`` naming the file).

    Its size is checked first: at most ``MAX_FILE_BYTES`` bytes and ``MAX_ITEMS`` commas, before it is parsed.
    """
    p = Path(path)
    try:
        size = p.stat().st_size
        if size > MAX_FILE_BYTES:
            raise ScenarioError(str(path), "file", f"{size} bytes: larger than the {MAX_FILE_BYTES} a scenario may be")
        text = p.read_text(encoding="utf-8")
        count_items(text, str(path))
        return tomllib.loads(text)
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


# a table header ([world], [[robots]]) or the start of an assignment (key = ...) at the start of a line
_MARK = re.compile(r"^[ \t]*(?:(\[\[?)[ \t]*([A-Za-z_\"][A-Za-z0-9_.\-\" ]*?)[ \t]*\]\]?|"
                   r"([A-Za-z0-9_\-]+(?:[ \t]*\.[ \t]*[A-Za-z0-9_\-]+)*)[ \t]*=)", re.MULTILINE)


def count_items(text: str, source: str) -> None:
    """Refuse TOML ``text`` with more than ``MAX_ITEMS`` commas, naming the key whose value holds most of them.

    Counting is done on the text (no parsing), so a file of millions of items is refused in milliseconds.
    """
    if text.count(",") <= MAX_ITEMS:
        return
    table, tables, worst = "", {}, (0, "file")
    marks = list(_MARK.finditer(text))
    for mark, after in zip(marks, [*marks[1:], None], strict=True):
        if mark[2] is not None:  # a header: [name] or [[name]] (the n-th of an array of tables)
            name = re.sub(r"[ \t\"]", "", mark[2])
            if mark[1] == "[[":
                tables[name] = tables.get(name, -1) + 1
                name = f"{name}[{tables[name]}]"
            table = name
            continue
        n = text.count(",", mark.start(), after.start() if after is not None else len(text))
        if n > worst[0]:
            name = re.sub(r"[ \t]", "", mark[3])
            worst = (n, f"{table}.{name}" if table else name)
    raise ScenarioError(source, worst[1], f"about {worst[0] + 1} items: a scenario holds at most {MAX_ITEMS} "
                                          "(counted as commas before the file is parsed)")


def resolve_scenario(raw: dict, source: str = "<scenario>", overrides: list[str] = ()) -> dict:
    """Validate and resolve a scenario given as a dict (as parsed from TOML); its data (``Scenario.to_dict``)."""
    return resolve(raw, source, overrides).to_dict()


def resolve(raw: dict, source: str = "<scenario>", overrides: list[str] = ()) -> Scenario:
    """Validate and resolve a scenario given as a dict (as parsed from TOML): the typed, resolved ``Scenario``.

    The caller's dict is left alone. In order: overrides; the model's types, defaults, limits and rules
    (``transport.scenario``); obstacles and map; each group placed from the run's seed (then connected placements
    redrawn), its behaviours checked by their classes; ``add`` events placed; event robot ids; checks.
    """
    raw = copy.deepcopy(raw)
    for item in overrides:
        apply_override(raw, item, source)
    with _naming(source):
        sc = decode(raw, Scenario)
        sc.check()
        _radio_rules(sc)
        _resolve_space(sc.world, source)
        rng = np.random.default_rng([sc.run.seed, 0x5CE7])
        for i, g in enumerate(sc.robots):
            _group(g, f"robots[{i}]", sc, source, rng)
        _connect_groups(sc, source, rng)
        for i, e in enumerate(sc.events):
            if e.add is not UNSET:
                e.add = _added(e.add, f"events[{i}].add", sc, source, rng)
        sc.check_event_ids()
    for i, c in enumerate(sc.checks):
        _check(c, f"checks[{i}]", source)
    sc.source = source
    return sc


def _radio_rules(sc: Scenario) -> None:
    """Each ``[[radio.rules]]`` table names a registered rule and gives it valid keys (world/linkrules.py)."""
    if sc.radio.rules:
        from world.linkrules import check_rules  # the world's registry; only scenarios that add rules load it

        check_rules(sc.radio, SpecError)


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


def _resolve_space(world: World, source: str) -> None:
    """Obstacles (convex polygons, boxes, C shapes) as ``xy`` polygons with their ``z``; ``world.map`` read or drawn."""
    from swarmactors.runs import maps
    from transport.space import convex

    resolved = []
    for i, ob in enumerate(world.obstacles):
        key = f"world.obstacles[{i}]"
        z = None if ob.z in (UNSET, None) else [float(v) for v in ob.z]
        if ob.c_shape is not UNSET:
            c = ob.c_shape
            parts = maps.c_shape([float(v) for v in c.center], float(c.size), float(c.thickness), c.opening, z)
        elif ob.box is not UNSET:
            parts = [maps.box(*points(ob.box, 2, f"{key}.box"), z)]
        else:
            xy = points(ob.xy, 2, f"{key}.xy")
            if not convex(np.array(xy)):
                raise SpecError(f"{key}.xy", "must be a convex polygon with non-zero area, vertices in order (split a "
                                             "non-convex obstacle into convex pieces)")
            parts = [{"xy": xy, "z": z}]
        resolved += [{**part, "loss_db": ob.loss_db} for part in parts]
    world.obstacles = [Obstacle(xy=ob["xy"], z=ob["z"], loss_db=ob["loss_db"]) for ob in resolved]
    if world.map is None:
        return
    m = decode({"file": world.map} if isinstance(world.map, str) else world.map, MapSource, "world.map")
    m.check()
    origin, cell = [float(v) for v in m.origin], float(m.cell)
    if m.file is not UNSET:
        path = Path(m.file)
        if not path.is_absolute() and source not in ("<scenario>", "--set"):
            path = Path(source).parent / path
        try:
            world.map = maps.read_map(path, tree_height=m.tree_height, cell=cell, origin=origin)
        except maps.MapError as exc:
            raise SpecError("world.map.file", str(exc)) from None
        return
    mz = m.maze
    try:
        rows = maps.maze(mz.cols, mz.rows, mz.seed, mz.corridor, mz.wall)
    except maps.MapError as exc:  # more cells than maps.MAX_MAP_CELLS
        raise ScenarioError(source, "world.map.maze", exc.message) from None
    world.map = maps.parse_map(["type octile", f"height {len(rows)}", f"width {len(rows[0])}", "map", *rows],
                               "maze", tree_height=m.tree_height, cell=cell, origin=origin)


def _group(g: Any, where: str, sc: Scenario, source: str, rng: np.random.Generator) -> None:
    """Place a group (its ``positions`` as given, else by its rule from ``rng``) and check its behaviours."""
    dims = sc.world.dims
    if g.positions is not None:
        g.positions = g.check_positions(g.positions, f"{where}.positions", dims, given=True)
        g.count, g.placement = len(g.positions), "explicit"
    else:
        g.positions = g.check_positions(_place(g, sc, where, rng).tolist(), f"{where}.positions", dims, given=False)
    space = _space(sc.world)
    if space is not None and not (dims == 2 and g.kind == "flying"):
        inside = np.flatnonzero(space.inside(_as3d(g.positions), ground=g.kind == "ground"))
        if inside.size:
            p = g.positions[inside[0]]
            raise SpecError(f"{where}.positions[{inside[0]}]", f"robot at {[round(v, 6) for v in p]} is inside an "
                            "obstacle" + ("" if g.placement == "explicit" else f" ({g.placement} placement)"))
    g.behaviors = [_behavior(b, f"{where}.behaviors[{i}]", source, g) for i, b in enumerate(g.behaviors)]


def _added(value: Any, where: str, sc: Scenario, source: str, rng: np.random.Generator) -> list:
    """An ``add`` event's robots, one spec each: a group placed as the scenario's, or specs checked as given."""
    if isinstance(value, list):
        return [robot_spec(s, sc.world.dims, sc.radio.range, f"{where}[{i}]") for i, s in enumerate(value)]
    _group(value, where, sc, source, rng)
    return robot_specs(value)


def _space(world: World):
    """The run's obstacles as a ``transport.space.Space`` (None when there are none)."""
    if not world.has_space:
        return None
    from transport.space import space_from_spec

    return space_from_spec(world.space_spec())


def _as3d(positions) -> np.ndarray:
    p = np.asarray(positions, dtype=float)
    return p if p.shape[1] == 3 else np.column_stack([p, np.zeros(len(p))])


def _area(g: Any, sc: Scenario, where: str) -> np.ndarray:
    dims = sc.world.dims
    if g.area is not None:
        return np.array(points(g.area, dims, f"{where}.area"))
    if sc.world.bounds is not None:
        return np.array(sc.world.bounds)
    side = math.sqrt(g.count) * g.range * 0.6
    return np.array([[0.0] * dims, [side, side] + [0.0] * (dims - 2)])


def _place(g: Any, sc: Scenario, where: str, rng: np.random.Generator) -> np.ndarray:
    """``count`` positions by the group's rule (docs/scenarios.md, "Placement rules")."""
    n, rule = g.count, g.placement
    lo, hi = _area(g, sc, where)
    dims = len(lo)
    if rule == "uniform":
        pts = lo + rng.random((n, dims)) * (hi - lo)
        space = _space(sc.world)
        if space is not None and not (dims == 2 and g.kind == "flying"):
            for _ in range(1000):  # redraw the robots that fell inside an obstacle
                inside = np.flatnonzero(space.inside(_as3d(pts) * ([1, 1, 0] if g.kind == "ground" else 1),
                                                     ground=g.kind == "ground"))
                if inside.size == 0:
                    break
                pts[inside] = lo + rng.random((inside.size, dims)) * (hi - lo)
        return pts
    spacing = g.spacing if g.spacing is not None else g.range * 0.9
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


def _connect_groups(sc: Scenario, source: str, rng: np.random.Generator) -> None:
    """Redraw groups with ``connected = true`` until the whole swarm's graph is connected."""
    groups = sc.robots
    if not any(g.connected for g in groups):
        return
    ranges = np.concatenate([[g.range] * g.count for g in groups])
    draws = iter(range(2000))

    def draw() -> np.ndarray:
        if next(draws):  # the first draw is the placement already made
            for i, g in enumerate(groups):
                if g.connected and g.placement != "explicit":
                    g.positions = _place(g, sc, f"robots[{i}]", rng).tolist()
        return np.vstack([np.array(g.positions) for g in groups])

    try:
        draw_until_connected(draw, ranges, attempts=2000, space=_space(sc.world) if sc.radio.occlusion else None)
    except ValueError:
        raise SpecError("robots.connected", "no connected placement found in 2000 draws; enlarge range or shrink "
                                            "area") from None


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
    """The obstacles that block links in a resolved scenario's data (``radio.occlusion`` on), or None."""
    w = sc["world"]
    if not sc["radio"]["occlusion"] or not (w["obstacles"] or w["map"]):
        return None
    from transport.space import space_from_spec

    return space_from_spec(w)


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


def _behavior(b: dict, where: str, source: str, group: Any) -> dict:
    """A behaviour spec, checked by its class.

    ``use`` (short name or module:Class), optional ``as`` (the name its report goes under; default the
    class's ``name``, else ``use``), then its parameters. A class's ``validate(params)`` checks them; one
    declared ``validate(params, group)`` also gets the robot group as resolved (its ``range``, ``sensing``,
    ``speed``...: a dict), for rules that tie a parameter to the robots it runs on.
    """
    try:
        cls = resolve_plugin(BEHAVIORS, b["use"])
    except PluginError as exc:
        raise ScenarioError(source, f"{where}.use", str(exc)) from None
    params = {k: v for k, v in b.items() if k not in ("use", "as")}
    frame = group.sensing_frame
    if frame not in getattr(cls, "frames", ("global",)):
        raise ScenarioError(source, where, f"behaviour {b['use']!r} does not support sensing_frame = {frame!r} "
                                           f"(it supports {', '.join(getattr(cls, 'frames', ('global',)))})")
    problem = params_problem(cls, params, msgspec.to_builtins(group))
    if problem:
        raise ScenarioError(source, where, f"{b['use']}: {problem}")
    return {"use": b["use"], "as": b.get("as") or getattr(cls, "name", "") or b["use"], **params}


def _check(c: dict, where: str, source: str) -> None:
    """A check's ``use`` names a registered check or ``module:function`` whose signature takes its parameters."""
    try:
        fn = resolve_plugin(CHECKS, c["use"])
    except PluginError as exc:
        raise ScenarioError(source, f"{where}.use", str(exc)) from None
    params = {k: v for k, v in c.items() if k != "use"}
    try:
        inspect.signature(fn).bind(None, **params)
    except TypeError as exc:
        raise ScenarioError(source, where, f"{c['use']}: {exc}") from None


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

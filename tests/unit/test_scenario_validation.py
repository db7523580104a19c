"""Scenario validation and resolution of ``swarmactors/runs/scenario.py``, without Zenoh.

Rules tested (docs/scenarios.md; the expected keys, types, ranges and defaults are the documentation's
tables written out here, not read from the module's schema):

* an unknown section, key or event action is an error naming the file and the key, and the message lists the
  known keys;
* a value of the wrong type is an error naming the key; an integer is accepted where a number is expected, a
  float is not accepted where an integer is, and booleans are never taken for numbers;
* a value out of range is an error naming the key, a value in range is kept as given (property tests over
  every numeric key); ``latency_min_s`` must not exceed ``latency_s``;
* errors are ``ScenarioError`` with the file (``source``) and the key, in the message ``file: key: ...``;
  loading a file names its path, a missing file and a TOML syntax error too;
* defaults are filled in for every key; ``ticks`` comes from ``duration`` as max(1, round(duration / dt)); a
  group's ``range`` defaults to ``radio.range`` and its ``sensing`` to its range; explicit positions give
  ``placement = "explicit"`` and the count; placement rules ``grid``, ``line``, ``ring`` and ``uniform``
  follow their formulas, from the seed, and ``connected = true`` gives a connected graph of mutual links;
* events: ``at`` is a tick, one action per event, ``kill`` of one id becomes a list, ``add`` becomes one spec per
  robot, robot ids must exist at the event's tick (robots added earlier count);
* ``--set`` overrides: dotted paths with list indices, the value read as TOML or else taken as a string,
  missing tables created, whole arrays replaced, a missing index is an error, later overrides win, and the
  result is validated like the file; the caller's dict is not changed;
* ``to_raw`` of a resolved scenario resolves to the same scenario.
"""

from __future__ import annotations

import copy
import math
from collections import deque

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmactors.runs.scenario import ScenarioError, apply_override, load, read_raw, resolve_scenario, set_value, to_raw

SRC = "tests/unit/scenario.toml"


def minimal(**sections) -> dict:
    raw = {"run": {"ticks": 5}, "robots": [{"count": 3}]}
    for name, value in sections.items():
        raw[name] = value if not isinstance(value, dict) else {**raw.get(name, {}), **value}
    return raw


def rejected(raw: dict, key: str, overrides=(), source: str = SRC) -> ScenarioError:
    """Assert that ``raw`` is refused naming ``source`` and ``key`` (or an item or key inside it); return the error."""
    with pytest.raises(ScenarioError) as info:
        resolve_scenario(raw, source, list(overrides))
    err = info.value
    assert err.source == source and (err.key == key or err.key.startswith((f"{key}[", f"{key}."))), (
        err.source, err.key, str(err))
    assert str(err).startswith(f"{source}: {err.key}: "), str(err)
    return err


# ------------------------------------------------------------------------------------------------ the tables

NUMBER, INTEGER, STRING, BOOLEAN = "number", "integer", "string", "boolean"

# (section, key): (type, default) - docs/scenarios.md tables
RUN = {
    "name": (STRING, "run"), "seed": (INTEGER, 0), "clock": (STRING, "lockstep"), "ticks": (INTEGER, None),
    "duration": (NUMBER, None), "dt": (NUMBER, 1.0), "watchdog_s": (NUMBER, 10.0), "join_timeout_s": (NUMBER, 60.0),
    "state_every": (INTEGER, 1), "trace": (BOOLEAN, True), "processes": (INTEGER, 0),
    "trace_compression": (STRING, "none"), "trace_commands": (BOOLEAN, False),  # issue 20
}
RADIO = {
    "range": (NUMBER, 1.0), "latency": (INTEGER, 1), "latency_s": (NUMBER, 0.01), "latency_min_s": (NUMBER, None),
    "loss": (NUMBER, 0.0), "model": (STRING, "bernoulli"), "delta": (NUMBER, 0.1), "bandwidth": (INTEGER, 0),
    "occlusion": (BOOLEAN, False),
    "loss_model": (STRING, "bernoulli"), "p_gb": (NUMBER, None), "p_bg": (NUMBER, None),
    "loss_good": (NUMBER, None), "loss_bad": (NUMBER, None), "rab": (BOOLEAN, False),
    "exclude": (STRING, "overheard"),  # issue 23: excluded robots overhear broadcasts
    "rules": ("list", []),  # more radio rules (world/linkrules.py)
    "channel": ("table", None),  # the shared channel (world/channel.py): off
}
WORLD = {"dims": (INTEGER, 2), "bounds": ("list", None), "objects": ("list", []), "max_robots": (INTEGER, 10_000),
         "obstacles": ("list", []), "map": ("table", None), "blocking": (BOOLEAN, False)}
GROUP = {
    "count": (INTEGER, None), "positions": ("list", None), "placement": (STRING, "uniform"), "area": ("list", None),
    "connected": (BOOLEAN, False), "spacing": (NUMBER, None), "range": (NUMBER, None), "sensing": (NUMBER, None),
    "speed": (NUMBER, None), "turn_rate": (NUMBER, None), "noise": (NUMBER, 0.0), "heading": (NUMBER, 0.0),
    "kind": (STRING, "ground"), "behaviors": ("list", []), "body_radius": (NUMBER, 0.0), "altitude": ("list", None),
    "climb_rate": (NUMBER, None), "knows_map": (BOOLEAN, False), "obstacle_rays": (INTEGER, 0),
    "sensing_frame": (STRING, "global"), "range_noise": (NUMBER, 0.0), "bearing_noise": (NUMBER, 0.0),
    "heading_offset": ("number or range", None), "sensing_to": (STRING, "center"),
    "clock_offset": ("number or range", 0.0), "clock_drift": ("number or range", 0.0),
    "tx_power_dbm": (NUMBER, None),  # with [radio.channel] (world/channel.py)
}
SECTIONS = {"run": RUN, "radio": RADIO, "world": WORLD}
EVENT_ACTIONS = ["kill", "kill_fraction", "add", "cut", "restore", "partition", "heal", "loss", "move", "stop"]

# numeric keys and the documented valid range
VALID = {
    ("run", "seed"): lambda v: v >= 0, ("run", "ticks"): lambda v: v > 0, ("run", "duration"): lambda v: v > 0,
    ("run", "dt"): lambda v: v > 0, ("run", "watchdog_s"): lambda v: v > 0,
    ("run", "join_timeout_s"): lambda v: v > 0, ("run", "state_every"): lambda v: v >= 0,
    ("run", "processes"): lambda v: v >= 0,
    ("radio", "range"): lambda v: v > 0, ("radio", "latency"): lambda v: v >= 1,
    ("radio", "latency_s"): lambda v: v > 0,
    ("radio", "latency_min_s"): lambda v: 0 <= v <= 0.01, ("radio", "loss"): lambda v: 0 <= v <= 1,
    ("radio", "delta"): lambda v: v > 0, ("radio", "bandwidth"): lambda v: v >= 0,
    ("world", "dims"): lambda v: v in (2, 3),
    ("group", "count"): lambda v: v > 0, ("group", "spacing"): lambda v: v > 0, ("group", "range"): lambda v: v > 0,
    ("group", "sensing"): lambda v: v > 0, ("group", "speed"): lambda v: v > 0, ("group", "turn_rate"): lambda v: v > 0,
    ("group", "noise"): lambda v: v >= 0, ("group", "heading"): lambda v: True,
    ("group", "body_radius"): lambda v: v >= 0, ("group", "climb_rate"): lambda v: v > 0,
    ("group", "obstacle_rays"): lambda v: v >= 0,
    ("radio", "p_gb"): lambda v: 0 <= v <= 1, ("radio", "p_bg"): lambda v: 0 <= v <= 1,
    ("radio", "loss_good"): lambda v: 0 <= v <= 1, ("radio", "loss_bad"): lambda v: 0 <= v <= 1,
    ("group", "range_noise"): lambda v: v >= 0, ("group", "bearing_noise"): lambda v: v >= 0,
}
ONE_OF = {("run", "clock"): ["lockstep", "realtime"], ("run", "trace_compression"): ["none", "zstd"],
          ("radio", "model"): ["bernoulli", "distance"],
          ("group", "placement"): ["uniform", "grid", "line", "ring"], ("group", "kind"): ["ground", "flying"],
          ("radio", "loss_model"): ["bernoulli", "gilbert"], ("group", "sensing_frame"): ["global", "local"],
          ("group", "sensing_to"): ["center", "surface"]}
GILBERT_KEYS = ("p_gb", "p_bg", "loss_good", "loss_bad")  # valid only with loss_model = "gilbert"


def with_value(section: str, key: str, value) -> tuple[dict, str]:
    """A minimal scenario with ``section.key = value``, and the key an error must name."""
    if section == "group":
        return minimal(robots=[{"count": 3, key: value}] if key != "count" else [{"count": value}]), f"robots[0].{key}"
    raw = minimal()
    if section == "radio" and (key in GILBERT_KEYS or (key, value) == ("loss_model", "gilbert")):
        raw["radio"] = {"loss_model": "gilbert", "p_gb": 0.1, "p_bg": 0.5}
    raw.setdefault(section, {})[key] = value
    if (section, key) == ("run", "duration"):
        del raw["run"]["ticks"]
    return raw, f"{section}.{key}"


# ------------------------------------------------------------------------------------------------ unknown keys


@pytest.mark.parametrize("section", ["run", "radio", "world"])
def test_unknown_key_names_file_and_key_and_lists_the_known_ones(section):
    err = rejected(minimal(**{section: {"colour": "red"}}), f"{section}.colour")
    assert f"(known: {', '.join(sorted(SECTIONS[section]))})" in str(err)


def test_unknown_key_in_a_group_and_unknown_section_and_unknown_event():
    err = rejected(minimal(robots=[{"count": 2}, {"count": 1, "wheels": 3}]), "robots[1].wheels")
    assert f"(known: {', '.join(sorted(GROUP))})" in str(err)
    err = rejected({**minimal(), "physics": {"g": 9.81}}, "physics")
    assert "checks, events, radio, robots, run, world" in str(err)
    err = rejected(minimal(events=[{"at": 1, "heal": True}, {"at": 2, "explode": True}]), "events[1].explode")
    assert ", ".join(EVENT_ACTIONS) in str(err)


# ------------------------------------------------------------------------------------------------ types

WRONG = {
    NUMBER: ["far", True, False, [1.0], {"x": 1}],
    INTEGER: [1.5, 2.0, True, "3", [1]],
    STRING: [3, True, ["lockstep"]],
    BOOLEAN: [1, 0, "true"],
}
TYPED = [(s, k, t) for s, table in (*SECTIONS.items(), ("group", GROUP)) for k, (t, _) in table.items() if t in WRONG]


@pytest.mark.parametrize("section,key,kind", TYPED, ids=[f"{s}.{k}" for s, k, _ in TYPED])
def test_wrong_type_is_rejected_naming_the_key(section, key, kind):
    for bad in WRONG[kind]:
        raw, name = with_value(section, key, bad)
        err = rejected(raw, name)
        assert repr(bad) in str(err)


@pytest.mark.parametrize("section,key", [(s, k) for s, k, t in TYPED if t == NUMBER])
def test_integer_accepted_where_a_number_is_expected(section, key):
    zero = (("radio", "loss"), ("radio", "latency_min_s"), *(("radio", k) for k in GILBERT_KEYS))
    value = 0 if (section, key) in zero else 2
    raw, _ = with_value(section, key, value)
    sc = resolve_scenario(raw, SRC)
    got = sc["robots"][0][key] if section == "group" else sc[section][key]
    assert got == value


# ------------------------------------------------------------------------------------------------ ranges

_KIND = {(s, k): t for s, k, t in TYPED}


def _values(kind):
    ints = st.integers(min_value=-1000, max_value=1000)
    if kind == INTEGER:
        return ints
    return ints | st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(st.sampled_from(sorted(VALID)).flatmap(lambda k: st.tuples(st.just(k), _values(_KIND[k]))))
def test_numbers_in_range_are_kept_and_out_of_range_rejected(case):
    (section, key), value = case
    if (section, key) == ("group", "count"):
        value = min(value, 40) if isinstance(value, int) else value  # keep placement cheap
    raw, name = with_value(section, key, value)
    if VALID[(section, key)](value):
        sc = resolve_scenario(raw, SRC)
        got = sc["robots"][0][key] if section == "group" else sc[section][key]
        assert got == value and type(got) is type(value)
    else:
        rejected(raw, name)


@pytest.mark.parametrize("section,key", sorted(ONE_OF))
def test_string_choices(section, key):
    for value in ONE_OF[(section, key)]:
        raw, _ = with_value(section, key, value)
        resolve_scenario(raw, SRC)
    raw, name = with_value(section, key, "sideways")
    rejected(raw, name)


def test_latency_min_must_not_exceed_latency():
    rejected(minimal(radio={"latency_s": 0.02, "latency_min_s": 0.03}), "radio.latency_min_s")
    sc = resolve_scenario(minimal(radio={"latency_s": 0.02, "latency_min_s": 0.02}), SRC)
    assert sc["radio"]["latency_min_s"] == 0.02


@pytest.mark.parametrize("raw,key", [
    (minimal(world={"bounds": [[0, 0], [0, 4]]}), "world.bounds"),  # min must be < max
    (minimal(world={"bounds": [[0, 0]]}), "world.bounds"),
    (minimal(world={"objects": [{"name": "a", "pos": [0, 0]}, {"name": "a", "pos": [1, 1]}]}), "world.objects[1]"),
    (minimal(robots=[{"count": 2, "positions": [[0, 0], [1, 1]]}]), "robots[0]"),  # not both
    (minimal(robots=[{"range": 1.0}]), "robots[0]"),  # neither
    (minimal(robots=[{"positions": [[0, float("nan")]]}]), "robots[0].positions"),
    (minimal(robots=[]), "robots"),
    ({"run": {}, "robots": [{"count": 1}]}, "run.ticks"),  # neither ticks nor duration
    (minimal(run={"ticks": 0}), "run.ticks"),
], ids=["bounds-empty", "bounds-one-corner", "duplicate-object", "count-and-positions", "no-count-no-positions",
        "nan-position", "no-groups", "no-ticks", "zero-ticks"])
def test_structural_errors_name_the_key(raw, key):
    rejected(raw, key)


# ------------------------------------------------------------------------------------------------ files


def test_loading_a_file_names_its_path(tmp_path):
    path = tmp_path / "lossy.toml"
    path.write_text('[run]\nticks = 3\n\n[radio]\nloss = 2\n\n[[robots]]\ncount = 2\n')
    with pytest.raises(ScenarioError) as info:
        load(path)
    assert str(info.value) == f"{path}: radio.loss: 2 must be in [0, 1]"
    with pytest.raises(ScenarioError) as info:
        read_raw(tmp_path / "missing.toml")
    assert info.value.key == "file" and str(tmp_path / "missing.toml") in str(info.value)
    path.write_text("[run\nticks = 3\n")
    with pytest.raises(ScenarioError) as info:
        load(path)
    assert info.value.key == "syntax" and str(info.value).startswith(f"{path}: syntax: ")


def test_load_applies_overrides_to_the_file(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[run]\nticks = 3\n\n[[robots]]\ncount = 2\n')
    sc = load(path, ["radio.loss=0.25", "run.name=from-file"])
    assert sc["radio"]["loss"] == 0.25 and sc["run"]["name"] == "from-file" and sc["source"] == str(path)


# ------------------------------------------------------------------------------------------------ defaults


def test_every_default_is_filled_in():
    sc = resolve_scenario(minimal(), SRC)
    for section, table in SECTIONS.items():
        want = {k: d for k, (_, d) in table.items()}
        want.update({"ticks": 5} if section == "run" else {})
        assert sc[section] == want, section
    g = sc["robots"][0]
    assert {k: g[k] for k in GROUP if k not in ("positions", "count", "range", "sensing")} == {
        k: d for k, (_, d) in GROUP.items() if k not in ("positions", "count", "range", "sensing")}
    assert g["count"] == 3 and len(g["positions"]) == 3
    assert g["range"] == 1.0 and g["sensing"] == 1.0
    assert sc["events"] == [] and sc["checks"] == [] and sc["source"] == SRC


def test_group_range_and_sensing_defaults():
    sc = resolve_scenario(minimal(radio={"range": 1.7}, robots=[
        {"count": 2}, {"count": 2, "range": 0.4}, {"count": 2, "range": 0.4, "sensing": 2.5},
        {"positions": [[0, 0], [1, 1]]}]), SRC)
    assert [(g["range"], g["sensing"]) for g in sc["robots"]] == [(1.7, 1.7), (0.4, 0.4), (0.4, 2.5), (1.7, 1.7)]
    explicit = sc["robots"][3]
    assert explicit["placement"] == "explicit" and explicit["count"] == 2
    assert explicit["positions"] == [[0.0, 0.0], [1.0, 1.0]]


@pytest.mark.parametrize("duration,dt,ticks", [(10, 1.0, 10), (1.0, 0.3, 3), (0.01, 1.0, 1), (2.6, 0.5, 5),
                                               (3.0, 0.25, 12)])
def test_ticks_from_duration(duration, dt, ticks):
    sc = resolve_scenario({"run": {"duration": duration, "dt": dt}, "robots": [{"count": 1}]}, SRC)
    assert sc["run"]["ticks"] == ticks == max(1, round(duration / dt))
    sc = resolve_scenario({"run": {"duration": duration, "dt": dt, "ticks": 7}, "robots": [{"count": 1}]}, SRC)
    assert sc["run"]["ticks"] == 7  # ticks, when given, wins


def test_positions_with_two_coordinates_in_3d_get_z_zero():
    sc = resolve_scenario(minimal(world={"dims": 3, "bounds": [[0, 0], [9, 9]]},
                                  robots=[{"positions": [[1, 2], [3, 4]]},
                                          {"positions": [[3, 4, 5]], "kind": "flying"}]), SRC)
    assert [g["positions"] for g in sc["robots"]] == [[[1.0, 2.0, 0.0], [3.0, 4.0, 0.0]], [[3.0, 4.0, 5.0]]]
    assert sc["world"]["bounds"] == [[0.0, 0.0, 0.0], [9.0, 9.0, 0.0]]


# ------------------------------------------------------------------------------------------------ placement


def test_grid_line_and_ring_follow_their_formulas():
    raw = minimal(robots=[
        {"count": 7, "placement": "grid", "spacing": 0.5, "area": [[1, 2], [9, 9]]},
        {"count": 4, "placement": "line", "spacing": 0.3, "area": [[-1, 1], [9, 9]]},
        {"count": 6, "placement": "ring", "spacing": 0.8, "area": [[2, 2], [9, 9]]},
        {"count": 3, "placement": "line", "range": 2.0, "area": [[0, 0], [9, 9]]},  # spacing = 0.9 range
    ])
    g = resolve_scenario(raw, SRC)["robots"]
    cols = math.ceil(math.sqrt(7))
    assert np.allclose(g[0]["positions"], [[1 + 0.5 * (i % cols), 2 + 0.5 * (i // cols)] for i in range(7)])
    assert np.allclose(g[1]["positions"], [[-1 + 0.3 * i, 1] for i in range(4)])
    ring = np.array(g[2]["positions"])
    assert np.allclose(np.linalg.norm(ring - [2, 2], axis=1), 0.8 / (2 * math.sin(math.pi / 6)))
    chords = np.linalg.norm(ring - np.roll(ring, -1, axis=0), axis=1)
    assert np.allclose(chords, 0.8)  # neighbours on the circle are `spacing` apart
    assert np.allclose(g[3]["positions"], [[1.8 * i, 0] for i in range(3)])


def test_uniform_placement_is_inside_the_area_and_follows_the_seed():
    def positions(seed, **extra):
        raw = minimal(run={"seed": seed}, robots=[{"count": 50, "area": [[1, -2], [3, 0]]}], **extra)
        return np.array(resolve_scenario(raw, SRC)["robots"][0]["positions"])

    p = positions(4)
    assert np.all(p >= [1, -2]) and np.all(p <= [3, 0])
    assert np.array_equal(p, positions(4)) and not np.array_equal(p, positions(5))
    # without area, the bounds; without bounds, the square of side sqrt(count) * range * 0.6 from the origin
    q = np.array(resolve_scenario(minimal(world={"bounds": [[5, 5], [6, 7]]}, robots=[{"count": 30}]), SRC)
                 ["robots"][0]["positions"])
    assert np.all(q >= [5, 5]) and np.all(q <= [6, 7])
    r = np.array(resolve_scenario(minimal(robots=[{"count": 25, "range": 2.0}]), SRC)["robots"][0]["positions"])
    assert np.all(r >= 0) and np.all(r <= math.sqrt(25) * 2.0 * 0.6)


def _mutual_graph_connected(pos, ranges) -> bool:
    n = len(pos)
    seen, todo = {0}, deque([0])
    while todo:
        a = todo.popleft()
        for b in range(n):
            d = math.dist(pos[a], pos[b])
            if b not in seen and d <= ranges[a] and d <= ranges[b]:
                seen.add(b)
                todo.append(b)
    return len(seen) == n


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_connected_placement_gives_a_connected_mutual_graph(seed):
    raw = minimal(run={"seed": seed}, world={"bounds": [[0, 0], [3, 3]]},
                  robots=[{"count": 20, "connected": True}, {"count": 5, "range": 1.5, "connected": True}])
    sc = resolve_scenario(raw, SRC)
    pos = [p for g in sc["robots"] for p in g["positions"]]
    ranges = [g["range"] for g in sc["robots"] for _ in g["positions"]]
    assert _mutual_graph_connected(pos, ranges)


# ------------------------------------------------------------------------------------------------ events


def test_events_are_resolved_and_checked():
    raw = minimal(events=[
        {"at": 4, "kill": 7},  # robot 7 exists from tick 2 on (added below)
        {"at": 2, "add": {"positions": [[0, 0], [1, 0], [2, 0], [3, 0], [4, 0]], "speed": 0.5}},
        {"at": 5, "partition": [[0, 1], [2, 3]]},
        {"at": 6, "heal": True},
    ])
    ev = resolve_scenario(raw, SRC)["events"]
    assert ev[0] == {"at": 4, "kill": [7]}
    assert [s["pos"] for s in ev[1]["add"]] == [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [4.0, 0.0]]
    assert all(s["speed"] == 0.5 and s["range"] == 1.0 for s in ev[1]["add"])
    err = rejected(minimal(events=[{"at": 1, "kill": [3]}]), "events[0].kill")
    assert "no robot 3 at tick 1 (ids 0..2 exist then)" in str(err)
    rejected(minimal(events=[{"at": 1, "kill": 7}, {"at": 2, "add": {"count": 5}}]), "events[0].kill")
    rejected(minimal(events=[{"at": -1, "heal": True}]), "events[0].at")
    rejected(minimal(events=[{"at": True, "heal": True}]), "events[0].at")
    rejected(minimal(events=[{"heal": True}]), "events[0]")
    rejected(minimal(events=[{"at": 1, "heal": True, "stop": True}]), "events[0]")
    rejected(minimal(events=[{"at": 1, "heal": False}]), "events[0].heal")
    rejected(minimal(events=[{"at": 1, "loss": 1.5}]), "events[0].loss")
    rejected(minimal(events=[{"at": 1, "cut": [[0, 1, 2]]}]), "events[0].cut")
    rejected(minimal(events=[{"at": 1, "move": {"object": "nowhere", "pos": [0, 0]}}]), "events[0].move")


@pytest.mark.parametrize("event", [{"at": 1, "cut": [[True, 2]]}, {"at": 1, "restore": [[0, True]]},
                                   {"at": 1, "partition": [[False, 1]]}], ids=["cut", "restore", "partition"])
def test_booleans_are_not_robot_ids_in_events(event):
    action = next(k for k in event if k != "at")
    rejected(minimal(events=[event]), f"events[0].{action}")


# ------------------------------------------------------------------------------------------------ non-finite


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("section,key,value", [
    ("run", "duration", math.inf), ("run", "dt", math.inf), ("radio", "range", math.inf),
    ("group", "spacing", math.inf), ("group", "heading", math.nan),
])
def test_non_finite_numbers_are_rejected(section, key, value):
    raw, name = with_value(section, key, value)
    if key == "spacing":
        raw["robots"][0]["placement"] = "line"
    if key == "heading":
        raw["robots"][0]["turn_rate"] = 0.5  # a unicycle: its NaN heading turns into NaN positions
    if key == "dt":
        raw["robots"][0]["behaviors"] = []
    rejected(raw, name)


# ------------------------------------------------------------------------------------------------ overrides


def test_override_values_are_read_as_toml_else_as_strings():
    raw = minimal(robots=[{"count": 3, "behaviors": [{"use": "flooding", "origin": 0, "at": 2, "expiry": 6}]}])
    before = copy.deepcopy(raw)
    sc = resolve_scenario(raw, SRC, [
        "radio.loss=0.1", "run.ticks=9", "run.trace=false", "run.name=lossy", 'run.clock="realtime"',
        "world.bounds=[[0, 0], [6, 6]]", "robots.0.count=4", "robots.0.behaviors.0.expiry=3",
        'checks=[{use = "flooding.reach"}]', "run.name=hello-world.v2",
    ])
    assert raw == before  # the caller's dict is left alone
    assert sc["radio"]["loss"] == 0.1 and sc["run"]["ticks"] == 9 and sc["run"]["trace"] is False
    assert sc["run"]["name"] == "hello-world.v2"  # not TOML: a string; the later override wins
    assert sc["run"]["clock"] == "realtime"
    assert sc["world"]["bounds"] == [[0.0, 0.0], [6.0, 6.0]]
    assert sc["robots"][0]["count"] == 4 and len(sc["robots"][0]["positions"]) == 4
    assert sc["robots"][0]["behaviors"][0]["expiry"] == 3
    assert sc["checks"] == [{"use": "flooding.reach"}]


def test_override_creates_missing_tables_and_replaces_arrays():
    raw = minimal(events=[{"at": 1, "heal": True}])
    assert "radio" not in raw
    sc = resolve_scenario(raw, SRC, ["radio.loss=0.3", "events=[]"])
    assert sc["radio"]["loss"] == 0.3 and sc["events"] == []


@pytest.mark.parametrize("item,key", [
    ("radio.loss", "radio.loss"),  # no '='
    ("=3", "=3"),  # no path
    ("radio.loss=2", "radio.loss"),  # validated like the file
    ("radio.colour=1", "radio.colour"),
    ("radio.range=-5", "radio.range"),
    ("run.ticks=true", "run.ticks"),
    ("robots.7.count=3", "robots.7.count"),  # the index must exist: overrides do not add groups
    ("robots.x.count=3", "robots.x.count"),
    ("robots.0.behaviors.0.expiry=3", "robots[0].behaviors"),  # the group has no behaviours: {"0": ...} made
    ("run.ticks.x=1", "run.ticks.x"),  # a key inside a value
])
def test_bad_overrides_name_the_item(item, key):
    rejected(minimal(), key, overrides=[item])


def test_apply_override_and_set_value_edit_a_raw_dict_in_place():
    raw = {"robots": [{"count": 1}, {"count": 2}]}
    apply_override(raw, "robots.1.count=5")
    apply_override(raw, "world.objects=[{name = \"t\", pos = [1, 2]}]")
    set_value(raw, "run.seed", 3)
    assert raw == {"robots": [{"count": 1}, {"count": 5}], "world": {"objects": [{"name": "t", "pos": [1, 2]}]},
                   "run": {"seed": 3}}


@pytest.mark.parametrize("item", ["run.ticks.x.y=1", "robots.0.count.a.b=1"])
def test_override_through_a_scalar_is_a_scenario_error(item):
    with pytest.raises(ScenarioError):
        resolve_scenario(minimal(), SRC, [item])


# ------------------------------------------------------------------------------------------------ to_raw


def test_to_raw_resolves_to_the_same_scenario():
    raw = minimal(run={"seed": 3, "duration": 4.0, "dt": 0.5}, radio={"loss": 0.1},
                  world={"bounds": [[0, 0], [3, 3]], "objects": [{"name": "t", "pos": [1, 1]}]},
                  robots=[{"count": 6, "connected": True, "noise": 0.1}, {"count": 2, "placement": "ring"}],
                  events=[{"at": 2, "add": {"count": 2, "speed": 0.2}}, {"at": 3, "kill": 1}])
    del raw["run"]["ticks"]
    sc = resolve_scenario(raw, SRC)
    again = resolve_scenario(to_raw(sc), SRC)
    assert again["run"] == {**sc["run"], "duration": None}  # ticks were resolved from the duration
    for key in ("radio", "world", "events", "checks"):
        assert again[key] == sc[key], key
    fields = ("positions", "range", "sensing", "noise", "speed", "heading", "kind", "behaviors")
    assert [{k: g[k] for k in fields} for g in again["robots"]] == [{k: g[k] for k in fields} for g in sc["robots"]]

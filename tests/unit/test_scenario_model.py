"""The scenario model (transport/scenario.py), without Zenoh.

Rules tested:

* one table of robot keys: a group and a robot spec have the same keys, types and defaults; a robot spec's data
  leaves out the sparse keys (caps, situated keys) while unset, as result.json's ``add`` events always did;
* errors name the key path (``robots[0].positions[0][1]``), the value and the rule; an unknown key lists the
  known ones and suggests the closest; a missing key is named;
* the rules between keys, each written once: Bernoulli ``loss`` under ``loss_model = "gilbert"`` is refused by
  the radio section, a ``loss`` event, the ``loss`` command and the medium, with one text;
  ``latency_min_s`` <= ``latency_s``; ``heading_offset`` only under local sensing; ``altitude`` only for flying
  robots in 3-D; a ground robot at z = 0 in 3-D;
* one robot-spec validation for a scenario's groups and the control ``add``: every value the issue found
  accepted by ``add`` (positions of 1e200, sizes of 1e308, 2**62 rays, infinite altitudes) is refused by both,
  and over random robot specs a scenario refuses exactly what ``add`` refuses (hypothesis);
* a control ``add`` queued by the world gets the scenario's defaults (the radio's range, sensing = range);
* the typed scenario and its data convert both ways unchanged, for every shipped scenario;
* the JSON Schema accepts every shipped scenario and refuses a bad key or value where the model does; the key
  tables of docs/scenarios.md are the model's (``python -m swarmactors.runs.schema --markdown --check``).
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmactors.runs import schema as schema_doc
from swarmactors.runs.scenario import ScenarioError, load, resolve, resolve_scenario
from transport.scenario import (
    MAX_COORD,
    MAX_OBSTACLE_RAYS,
    PLACEMENT_KEYS,
    ROBOT_FIELDS,
    SPARSE,
    Radio,
    RobotGroup,
    RobotSpec,
    Scenario,
    SpecError,
    action_problem,
    decode,
    robot_spec,
    robots_to_dicts,
)
from world import Simulation
from world.radio import Medium

SCENARIOS = sorted((Path(__file__).resolve().parents[2] / "scenarios").glob("*.toml"))
SRC = "model.toml"


def refused(raw: dict) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        resolve(raw, SRC)
    return info.value


def base(**sections) -> dict:
    return {"run": {"ticks": 3}, "robots": [{"count": 2}], **sections}


# ------------------------------------------------------------------------------------------------ one table


def test_a_group_and_a_robot_spec_share_one_table_of_keys():
    group = {f.name: f for f in msgspec.structs.fields(RobotGroup)}
    spec = {f.name: f for f in msgspec.structs.fields(RobotSpec)}
    assert list(group) == [n for n, _, _ in PLACEMENT_KEYS] + list(ROBOT_FIELDS)
    assert list(spec) == ["pos", *ROBOT_FIELDS]
    for name in ROBOT_FIELDS:
        assert group[name].type == spec[name].type and group[name].default == spec[name].default, name
    assert set(SPARSE) < set(ROBOT_FIELDS)


def test_a_robot_spec_as_data_leaves_out_unset_sparse_keys():
    spec = robot_spec({"pos": [1, 2], "speed": 0.5}, 2, 1.5)
    (data,) = robots_to_dicts([spec])
    assert data == {"pos": [1.0, 2.0], "range": 1.5, "sensing": 1.5, "speed": 0.5, "noise": 0.0, "heading": 0.0,
                    "kind": "ground", "body_radius": 0.0, "knows_map": False, "obstacle_rays": 0, "behaviors": []}
    assert list(data) == [k for k in ["pos", *ROBOT_FIELDS] if k in data]  # the model's order
    (local,) = robots_to_dicts([robot_spec({"pos": [0, 0], "sensing_frame": "local", "clock_drift": [-1, 1]}, 2, 1.0)])
    assert local["sensing_frame"] == "local" and local["clock_drift"] == [-1, 1] and "range_noise" not in local


# ------------------------------------------------------------------------------------------------ errors


@pytest.mark.parametrize("raw,key,text", [
    (base(radio={"latncy": 2}), "radio.latncy",
     "unknown key; did you mean 'latency'? (known: bandwidth, channel, delta,"),
    (base(robots=[{"count": 1, "rnge": 2}]), "robots[0].rnge", "did you mean 'range'?"),
    (base(physics={}), "physics", "unknown section (known: checks, events, radio, robots, run, world)"),
    (base(events=[{"at": 1, "kil": [0]}]), "events[0].kil", "unknown event; did you mean 'kill'? (known: kill,"),
    (base(robots=[{"positions": [[0, 1e200]]}]), "robots[0].positions[0][1]", "1e+200 must be in [-1e+09, 1e+09]"),
    (base(robots=[{"count": 1, "range": 1e308}]), "robots[0].range", "1e+308 must be > 0 and <= 1e+09"),
    (base(robots=[{"count": 1, "speed": math.inf}]), "robots[0].speed", "inf is not a finite number"),
    (base(robots=[{"count": 1, "kind": "boat"}]), "robots[0].kind", "'boat' must be one of 'flying', 'ground'"),
    (base(robots=[{"count": 1, "obstacle_rays": 2**62}]), "robots[0].obstacle_rays", f"must be in 0..{1024}"),
    (base(robots=[{"count": 1, "noise": "lots"}]), "robots[0].noise", "'lots' is a str, expected int or float"),
    (base(robots=[{"count": 1, "behaviors": [{"as": "x"}]}]), "robots[0].behaviors[0]", "use ="),
    (base(run={"ticks": 2.5}), "run.ticks", "2.5 is a float, expected int"),
    (base(world={"max_robots": 0}), "world.max_robots", "0 must be in 1..1000000"),
    (base(events=[{"kill": [0]}]), "events[0].at", "is required"),
    ({"run": {"ticks": 3}}, "robots", "must hold at least one [[robots]] group"),
    (base(world={"obstacles": [{"box": [[0, 0], [1, 1]], "xy": [[0, 0], [1, 0], [0, 1]]}]}), "world.obstacles[0]",
     "exactly one of xy, box or c_shape"),
    (base(checks=[{"name": "x"}]), "checks[0]", 'use = "family.check"'),
])
def test_errors_name_the_key_path_the_value_and_the_rule(raw, key, text):
    err = refused(raw)
    assert err.key == key and str(err).startswith(f"{SRC}: {key}: ") and text in str(err), str(err)


def test_decode_names_keys_under_a_prefix():
    with pytest.raises(SpecError) as info:
        decode({"pos": [0, 0], "sensing": -1}, RobotSpec, "add[3]")
    assert info.value.key == "add[3].sensing" and "must be > 0" in info.value.problem


# ------------------------------------------------------------------------------------------------ cross-key rules


def test_no_bernoulli_loss_under_gilbert_one_rule_everywhere():
    gilbert = {"loss_model": "gilbert", "p_gb": 0.1, "p_bg": 0.5}
    radio = Radio.from_dict(gilbert)
    text = radio.loss_problem(0.2)
    assert text and Radio.from_dict({}).loss_problem(0.2) is None
    err = refused(base(radio={**gilbert, "loss": 0.2}))
    assert err.key == "radio.loss" and text in str(err)
    err = refused(base(radio=gilbert, events=[{"at": 1, "loss": 0.2}]))
    assert err.key == "events[0].loss" and text in str(err)
    assert text in action_problem({"loss": 0.2}, radio=radio)
    with pytest.raises(ValueError, match="gilbert"):
        Medium(radio, seed=1).set_loss(0.2)
    assert (radio.loss_good, radio.loss_bad) == (0.0, 1.0)  # the Gilbert-Elliott defaults, filled once
    assert refused(base(radio={"p_gb": 0.1})).key == "radio.p_gb"
    assert refused(base(radio={"loss_model": "gilbert", "p_gb": 0.1})).key == "radio.p_bg"


@pytest.mark.parametrize("raw,key", [
    (base(radio={"latency_s": 0.01, "latency_min_s": 0.02}), "radio.latency_min_s"),
    (base(robots=[{"count": 1, "heading_offset": 0.5}]), "robots[0].heading_offset"),
    (base(robots=[{"count": 1, "clock_offset": [2, 1]}]), "robots[0].clock_offset"),
    (base(robots=[{"count": 1, "clock_drift": [-2e5, 0]}]), "robots[0].clock_drift"),
    (base(robots=[{"count": 1, "kind": "flying", "altitude": [0, 2]}]), "robots[0].altitude"),  # 2-D
    (base(world={"dims": 3}, robots=[{"count": 1, "altitude": [0, 2]}]), "robots[0].altitude"),  # ground
    (base(world={"dims": 3}, robots=[{"count": 1, "kind": "flying", "altitude": [2, 1]}]), "robots[0].altitude"),
    (base(world={"dims": 3}, robots=[{"positions": [[0, 0, 1]]}]), "robots[0].positions[0]"),  # ground above 0
    (base(world={"dims": 3}, robots=[{"positions": [[0, 0, 3]], "kind": "flying", "altitude": [0, 2]}]),
     "robots[0].positions[0]"),
    (base(robots=[{"count": 2, "placement": "explicit"}]), "robots[0].placement"),
    (base(world={"bounds": [[0, 0], [0, 1]]}), "world.bounds"),
    (base(world={"objects": [{"name": "a", "pos": [0, 0]}, {"name": "a", "pos": [1, 1]}]}), "world.objects[1]"),
    (base(events=[{"at": 1, "heal": True, "stop": True}]), "events[0]"),
    (base(events=[{"at": 1, "kill": [2]}]), "events[0].kill"),  # robots 0 and 1 only
    (base(events=[{"at": 1, "add": {"count": 1001}}]), "events[0].add.count"),  # one add: at most 1000
])
def test_rules_between_keys(raw, key):
    assert refused(raw).key == key


def test_derived_defaults_are_filled_in_once():
    sc = resolve(base(radio={"range": 2.5}, run={"duration": 4.0, "dt": 0.5, "ticks": None},
                      robots=[{"count": 1}, {"count": 1, "range": 0.5}, {"count": 1, "sensing": 4}]), SRC)
    assert sc.run.ticks == 8
    assert [(g.range, g.sensing) for g in sc.robots] == [(2.5, 2.5), (0.5, 0.5), (2.5, 4)]
    assert sc.radio.c_min_s == sc.radio.latency_s


# ------------------------------------------------------------------------------------------------ one robot validation

# Values the security campaign found accepted by a control ``add`` (issue 42), each refused by a scenario.
REFUSED = [
    {"pos": [1e200, 1.0]}, {"pos": [1.0, 1e308]}, {"pos": [MAX_COORD * 2, 0.0]},
    {"pos": [1.0, 1.0], "range": 1e308}, {"pos": [1.0, 1.0], "speed": 1e308}, {"pos": [1.0, 1.0], "sensing": 1e308},
    {"pos": [1.0, 1.0], "body_radius": 1e308}, {"pos": [1.0, 1.0], "clock_drift": 1e308},
    {"pos": [1.0, 1.0], "clock_offset": 1e308}, {"pos": [1.0, 1.0], "clock_drift": [0.0, 1e308]},
    {"pos": [1.0, 1.0], "obstacle_rays": 2**62}, {"pos": [1.0, 1.0], "obstacle_rays": 10**12},
    {"pos": [1.0, 1.0], "obstacle_rays": MAX_OBSTACLE_RAYS + 1}, {"pos": [1.0, 1.0], "altitude": [math.inf, -math.inf]},
    {"pos": [1.0, 1.0], "speed": math.inf}, {"pos": [1.0, 1.0], "noise": math.nan}, {"pos": [1.0]},
    {"pos": [1.0, 1.0], "heading_offset": 0.3}, {"pos": [1.0, 1.0], "kind": "flying", "altitude": [0.0, 1.0]},
    {"pos": [1.0, 1.0], "behaviors": [{"use": ""}]},
]


@pytest.mark.parametrize("spec", REFUSED, ids=[str(s)[:60] for s in REFUSED])
def test_every_value_a_scenario_refuses_is_refused_by_add(spec):
    group = {"positions": [spec["pos"]], **{k: v for k, v in spec.items() if k != "pos"}}
    err = refused(base(robots=[group]))
    problem = action_problem({"add": [spec]}, robots=2, dims=2)
    assert problem is not None and problem.startswith("add[0]"), problem
    # the same rule: the scenario's message without its key path is the add's
    assert str(err).split(": ", 2)[2] == problem.split(": ", 1)[1], (str(err), problem)


VALUES = st.sampled_from([0, 1, 2, -1, 0.5, 1e9, 2e9, 1e200, 1e308, math.inf, -math.inf, math.nan, True, "x",
                          [0, 1], [1, 0], [0.0, 2.0], [math.inf, -math.inf], 2**62, 1024, 1025, None, "ground",
                          "flying", "local", "global", "surface", "center"])
KEYS = [k for k in ROBOT_FIELDS if k != "behaviors"]


@settings(max_examples=300, deadline=None)
@given(st.dictionaries(st.sampled_from(KEYS), VALUES, max_size=4),
       st.lists(st.sampled_from([0.0, 1.5, -3.0, 1e200, math.nan, 2]), min_size=1, max_size=4),
       st.sampled_from([2, 3]))
def test_a_scenario_refuses_exactly_what_add_refuses(params, pos, dims):
    raw = base(world={"dims": dims}, robots=[{"positions": [pos], **params}])
    try:
        resolve_scenario(raw, SRC)
        scenario_ok = True
    except ScenarioError:
        scenario_ok = False
    assert scenario_ok == (action_problem({"add": [{"pos": pos, **params}]}, dims=dims) is None), (params, pos)


def test_a_queued_control_add_gets_the_scenario_defaults():
    world = Simulation(resolve(base(radio={"range": 2.5}), SRC))
    world.faults.queue({"add": [{"pos": [1.0, 1.0]}, {"pos": [0, 0], "range": 0.5}]})
    (action,) = world.faults.queued
    assert [(s.range, s.sensing, s.pos) for s in action["add"]] == [(2.5, 2.5, [1.0, 1.0]), (0.5, 0.5, [0.0, 0.0])]
    with pytest.raises(ValueError, match=r"add\[0\].range: 1e\+308"):
        world.faults.queue({"add": [{"pos": [1.0, 1.0], "range": 1e308}]})
    assert len(world.faults.queued) == 1


def test_control_commands_and_scenario_events_apply_alike():
    """A queued command is typed as the scenario event of the same name, so the world applies both one way."""
    raw = base(world={"objects": [{"name": "t", "pos": [0, 0]}]}, robots=[{"count": 4}],
               events=[{"at": 0, "move": {"object": "t", "pos": [1, 1]}}, {"at": 0, "kill": 3}])
    world = Simulation(resolve(raw, SRC))
    commands = {"kill": 2, "kill_fraction": 0.0, "add": [{"pos": [0.5, 0.5]}], "cut": [[0, 1]],
                "restore": [[0, 1]], "partition": [[0], [1]], "heal": True, "loss": 0.1,
                "move": {"object": "t", "pos": [2, 2]}}
    for name, value in commands.items():
        world.faults.queue({name: value})
    due = world.faults.due(0)
    assert [next(iter(a)) for a, _ in due] == ["move", "kill", *commands]
    for action, source in due:
        world.faults.apply(action, source, 0)
    assert world.objects["t"] == [2.0, 2.0] and world.medium.config.loss == 0.1
    assert not world.robots.alive[2] and not world.robots.alive[3] and len(world.robots) == 5


# ------------------------------------------------------------------------------------------------ typed and data


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.name for p in SCENARIOS])
def test_typed_scenario_and_its_data_convert_unchanged(path):
    data = load(path)
    typed = Scenario.from_dict(data)
    assert typed.to_dict() == data
    assert msgspec.json.encode(typed.to_dict()) == msgspec.json.encode(data)  # same keys in the same order
    assert len(typed.robot_specs()) == sum(g["count"] for g in data["robots"])


def test_positions_are_floats_of_the_world_dims():
    sc = resolve(base(world={"dims": 3}, robots=[{"positions": [[1, 2]]}]), SRC)
    assert sc.robots[0].positions == [[1.0, 2.0, 0.0]]
    assert all(type(v) is float for p in sc.robots[0].positions for v in p)


# ------------------------------------------------------------------------------------------------ schema and docs


def test_the_json_schema_checks_files_as_the_model_does():
    jsonschema = pytest.importorskip("jsonschema")
    from transport.scenario import schema

    validator = jsonschema.Draft7Validator(schema())
    jsonschema.Draft7Validator.check_schema(schema())
    for path in SCENARIOS:
        assert not list(validator.iter_errors(tomllib.loads(path.read_text()))), path.name
    for raw in (base(radio={"loss": 2}), base(radio={"bogus": 1}), base(robots=[{"count": 1, "rnge": 1}]),
                base(events=[{"at": 1, "heal": True, "stop": True}]), {"run": {"ticks": 1}, "robots": []},
                base(robots=[{"count": 1, "obstacle_rays": 2000}])):
        assert list(validator.iter_errors(raw)), raw
        refused(raw)


def test_the_docs_key_tables_are_generated_from_the_model():
    doc = Path(__file__).resolve().parents[2] / "docs" / "scenarios.md"  # the checkout's (CI installs a wheel)
    assert schema_doc.main(["--markdown", "--check", "--doc", str(doc)]) == 0, \
        "run: python -m swarmactors.runs.schema --markdown"
    text = doc.read_text()
    for name in schema_doc.TABLES:
        assert schema_doc.table(name) in text
    assert "| `obstacle_rays` | integer in 0..1024 |" in schema_doc.table("robots")

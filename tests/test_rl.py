"""The swarm as a PettingZoo environment (swarmactors.rl, docs/rl.md).

PettingZoo's own API and seed tests, determinism, what agents observe (never the oracle), the radio deciding who
hears, rewards, bad input.
"""

from __future__ import annotations

import asyncio
import math
import runpy
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pettingzoo")

from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, seed_test, state_test  # noqa: E402
from pettingzoo.utils.conversions import parallel_to_aec  # noqa: E402

from swarmactors.rl import Dispersion, GoalRelay, Task, parallel_env  # noqa: E402

EXAMPLES = Path(__file__).resolve().parent.parent / "docs" / "examples" / "rl_tasks.py"


def swarm(n=8, ticks=30, kill=(2, 5), **radio):
    """A small arena with a kill at tick 10 (two agents terminate) and a lossy radio."""
    return {"run": {"name": "rl", "ticks": ticks, "seed": 1},
            "radio": {"range": 3.0, "latency": 2, "loss": 0.2, **radio},
            "world": {"bounds": [[0.0, 0.0], [10.0, 10.0]]},
            "robots": [{"count": n, "speed": 0.5, "area": [[3.0, 3.0], [7.0, 7.0]]}],
            "events": [{"at": 10, "kill": list(kill)}] if kill else []}


def line(positions, ticks=20, **kw):
    radio = {"range": 3.0, "latency": 2, **kw.pop("radio", {})}
    group = {"positions": positions, "speed": 1.0, **kw}
    return {"run": {"name": "rl-line", "ticks": ticks, "seed": 0}, "radio": radio,
            "world": {"bounds": [[-20.0, -20.0], [20.0, 20.0]]}, "robots": [group]}


# ------------------------------------------------------------------ PettingZoo's own tests
@pytest.mark.parametrize("flatten", [False, True])
def test_pettingzoo_parallel_api_test_passes(flatten):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # not even a warning from the parallel API test
        parallel_api_test(parallel_env(swarm(), task="dispersion", flatten=flatten), num_cycles=100)


def test_pettingzoo_seed_tests_pass():
    parallel_seed_test(lambda: parallel_env(swarm(), task="dispersion"))
    seed_test(lambda: parallel_to_aec(parallel_env(swarm(), task="dispersion", flatten=True)))


@pytest.mark.filterwarnings("ignore:Agent's m.* observation space value is .*infinity")  # pose, unbounded
def test_pettingzoo_aec_api_and_state_tests_pass_on_the_converted_env():
    api_test(parallel_to_aec(parallel_env(swarm(), task="dispersion", flatten=True)), num_cycles=50)
    state_test(parallel_to_aec(parallel_env(swarm(), task="dispersion")), parallel_env(swarm(), task="dispersion"))


# ------------------------------------------------------------------ determinism
def rollout(env, seed, steps=25, action_seed=7):
    rng = np.random.default_rng(action_seed)
    obs, _ = env.reset(seed=seed)
    seen = [obs]
    for _ in range(steps):
        if not env.agents:
            break
        actions = {a: rng.uniform(-1, 1, env.action_space(a).shape).astype(np.float32) for a in env.agents}
        obs, rewards, *_ = env.step(actions)
        seen.append((obs, rewards))
    return seen, env.truth.pos.copy()


def same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    return np.array_equal(np.asarray(a), np.asarray(b))


def test_same_seed_and_actions_give_the_same_observations_and_another_seed_does_not():
    sc = swarm(loss=0.3)  # the loss draws are part of what must repeat
    one, pos1 = rollout(parallel_env(sc, task="dispersion"), seed=5)
    two, pos2 = rollout(parallel_env(sc, task="dispersion"), seed=5)
    assert same(one, two) and np.array_equal(pos1, pos2)
    env = parallel_env(sc, task="dispersion")
    rollout(env, seed=9)  # an episode in between changes nothing for the next seeded one
    again, _ = rollout(env, seed=5)
    assert same(one, again)
    other, _ = rollout(parallel_env(sc, task="dispersion"), seed=6)
    assert not same(one, other)
    # received messages are in the observations, so the determinism covers the radio's decisions
    assert any(o["messages"][:, -1].any() for obs, _ in one[1:] for o in obs.values())


def test_reset_without_a_seed_starts_at_the_scenarios_seed_then_counts_up():
    env = parallel_env(swarm(), task="dispersion")
    env.reset()
    assert env.episode_seed == 1
    env.reset()
    assert env.episode_seed == 2
    env.reset(seed=40)
    env.reset()
    assert env.episode_seed == 41


# ------------------------------------------------------------------ what an agent observes
def test_observations_lie_in_their_spaces_and_agents_end_by_death_or_time():
    env = parallel_env(swarm(ticks=14), task="dispersion", observe=("pose", "neighbors", "messages"))
    obs, _ = env.reset(seed=0)
    for a, o in obs.items():
        assert env.observation_space(a).contains(o)
    ended = {}
    while env.agents:
        obs, rewards, term, trunc, _ = env.step({a: env.action_space(a).sample() for a in env.agents})
        for a in obs:
            assert env.observation_space(a).contains(obs[a])
            if term[a] or trunc[a]:
                ended[a] = ("killed" if term[a] else "time", env.run.tick)
    assert ended["robot_2"] == ended["robot_5"] == ("killed", 10)  # the step that reaches tick 10 ends them
    assert all(v == ("time", 14) for k, v in ended.items() if k not in ("robot_2", "robot_5"))


def test_the_radio_decides_who_hears_with_latency_range_and_loss():
    sc = line([[0.0, 0.0], [2.0, 0.0], [10.0, 0.0]], radio={"latency": 2})
    env = parallel_env(sc, observe=("messages",), messages=2, payload=2)
    env.reset(seed=0)
    say = {"robot_0": np.array([0, 0, 0.5, -0.25, 1], dtype=np.float32)}  # vx, vy, payload, send
    heard = []
    for _ in range(4):
        obs, *_ = env.step(say)
        say = {}
        heard.append({a: o["messages"][o["messages"][:, -1] > 0, :2].tolist() for a, o in obs.items()})
    assert [h["robot_1"] for h in heard] == [[], [[0.5, -0.25]], [], []]  # sent at tick 0, due at tick 2
    assert all(h["robot_2"] == [] and h["robot_0"] == [] for h in heard)  # out of range; not its own
    lossy = parallel_env(line([[0.0, 0.0], [2.0, 0.0]], radio={"loss": 1.0}), observe=("messages",), payload=2)
    lossy.reset(seed=0)
    for _ in range(3):
        obs, *_ = lossy.step({"robot_0": np.array([0, 0, 0.5, 0.5, 1], dtype=np.float32)})
        assert not obs["robot_1"]["messages"][:, -1].any()
    assert lossy.run.sim.counters.dropped["loss"] == 3


@pytest.mark.parametrize("frame", ["global", "local"])
def test_a_neighbours_bearing_is_in_the_frame_of_the_velocity_command(frame):
    extra = {"sensing_frame": "local", "heading_offset": 1.0} if frame == "local" else {}
    env = parallel_env(line([[0.0, 0.0], [2.0, 1.5]], **extra), observe=("neighbors", "pose"), neighbors=2)
    obs, _ = env.reset(seed=0)
    rng, bearing, valid = obs["robot_0"]["neighbors"][0]
    assert valid == 1.0 and obs["robot_0"]["neighbors"][1, -1] == 0.0
    assert rng == pytest.approx(2.5, abs=1e-5)
    if frame == "local":
        assert obs["robot_0"]["pose"][:2] == pytest.approx([0, 0]) and obs["robot_0"]["pose"][2] == pytest.approx(1.0)
    env.step({"robot_0": np.array([math.cos(bearing), math.sin(bearing)], dtype=np.float32)})
    assert np.linalg.norm(env.truth.pos[1] - env.truth.pos[0]) == pytest.approx(1.5, abs=1e-4)  # went straight at it


def test_objects_are_observed_only_while_sensed_and_rays_are_capped_at_the_sensing_range():
    sc = line([[0.0, 0.0], [8.0, 0.0]], sensing=2.0, obstacle_rays=4)
    sc["world"]["objects"] = [{"name": "goal", "pos": [9.0, 1.0], "known_by": "sensing"}]
    sc["world"]["obstacles"] = [{"box": [[-1.5, -5.0], [-1.0, 5.0]]}]
    env = parallel_env(sc, observe=("objects", "rays"))
    obs, _ = env.reset(seed=0)
    assert obs["robot_0"]["objects"].tolist() == [[0.0, 0.0, 0.0]]
    assert obs["robot_1"]["objects"].tolist() == [[1.0, 1.0, 1.0]]
    rays = obs["robot_0"]["rays"]  # ray k at heading + k * 90 degrees: the wall 1 behind robot 0
    assert rays.tolist() == pytest.approx([2.0, 2.0, 1.0, 2.0])


def test_robots_outside_the_rl_groups_keep_their_behaviours_and_are_not_agents():
    sc = swarm(n=4, kill=())
    sc["robots"][0]["behaviors"] = [{"use": "rl"}]
    sc["robots"].append({"positions": [[5.0, 5.0]], "behaviors": [{"use": "beacon"}]})
    env = parallel_env(sc)
    obs, _ = env.reset(seed=0)
    assert env.possible_agents == ["robot_0", "robot_1", "robot_2", "robot_3"]
    for _ in range(3):
        obs, *_ = env.step({})
    assert env.run.sim.counters.sent >= 3  # the beacon beacons; its frames are not rl payloads
    assert not any(o["messages"][:, -1].any() for o in obs.values())


# ------------------------------------------------------------------ rewards (oracle side)
def test_dispersion_rewards_coverage_times_the_connected_share():
    sc = line([[1.0, 1.0], [2.0, 1.0], [15.0, 15.0]])
    env = parallel_env(sc, task=Dispersion(radius=1.0, cells=40))
    env.reset(seed=0)
    _, rewards, *_ , infos = env.step({})
    m = infos["robot_0"]["task"]
    assert m["component"] == pytest.approx(2 / 3)
    assert m["coverage"] == pytest.approx(3 * math.pi / 1600, rel=0.15)  # three unit discs in a 40 x 40 box
    assert list(rewards.values()) == [pytest.approx(m["coverage"] * 2 / 3)] * 3


def test_goal_relay_rewards_distance_and_ends_when_every_agent_is_there():
    sc = line([[0.0, 0.0], [1.0, 0.0]])
    sc["world"]["objects"] = [{"name": "goal", "pos": [3.0, 0.0], "known_by": "sensing"}]
    env = parallel_env(sc, task=GoalRelay(radius=0.6), observe=("objects",))
    env.reset(seed=0)
    go = {a: np.array([1.0, 0.0], dtype=np.float32) for a in env.agents}
    _, rewards, term, *_ = env.step(go)  # at 1 and 2: distances 2 and 1
    diag = math.hypot(40, 40)
    assert rewards == {"robot_0": pytest.approx(-2 / diag), "robot_1": pytest.approx(-1 / diag)}
    _, _, term, *_ = env.step(go)  # at 2 and 3
    assert not any(term.values())
    _, _, term, *_ = env.step({"robot_0": go["robot_0"]})  # both at 3
    assert all(term.values()) and env.agents == []


def test_a_reward_function_sees_the_truth_and_may_answer_per_agent_or_per_robot():
    seen = []

    def reward(truth):
        seen.append(truth.tick)
        return {"robot_1": float(truth.pos[1, 0])}

    env = parallel_env(line([[0.0, 0.0], [2.0, 0.0]]), task=reward, observe=("pose",))
    env.reset(seed=0)
    _, rewards, *_ = env.step({"robot_1": np.array([1, 0], dtype=np.float32)})
    assert rewards == {"robot_0": 0.0, "robot_1": pytest.approx(3.0)} and seen == [1]
    env = parallel_env(line([[0.0, 0.0], [2.0, 0.0]]), task=lambda t: t.pos[:, 0])
    env.reset(seed=0)
    assert env.step({})[1] == {"robot_0": 0.0, "robot_1": 2.0}
    env = parallel_env(line([[0.0, 0.0], [2.0, 0.0]]), task=lambda t: np.zeros(5))
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"reward of shape \(5,\)"):
        env.step({})


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(("kwargs", "message"), [
    ({"observe": ("pose", "smell")}, "observe = .*smell"),
    ({"observe": ("rays",)}, "obstacle_rays > 0"),
    ({"neighbors": -1}, "neighbors = -1"),
    ({"payload": 0}, "payload = 0"),
    ({"task": "tidy"}, "task 'tidy' is not one of dispersion, relay"),
    ({"task": "relay"}, "object named 'goal'"),
    ({"max_steps": 0}, "max_steps = 0"),
])
def test_bad_settings_are_refused_with_the_setting_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        parallel_env(swarm(), **kwargs)


def test_bad_scenarios_and_actions_are_refused_clearly():
    sc = swarm()
    del sc["robots"][0]["speed"]
    with pytest.raises(ValueError, match="no speed cap; give the group a speed or pass max_speed"):
        parallel_env(sc)
    parallel_env(sc, max_speed=1.0)
    del sc["world"]["bounds"]
    with pytest.raises(ValueError, match="'dispersion' needs world.bounds"):
        parallel_env(sc, task="dispersion", max_speed=1.0)
    env = parallel_env(swarm())
    with pytest.raises(RuntimeError, match="step before reset"):
        env.step({})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="unknown agent 'robot_99'"):
        env.step({"robot_99": np.zeros(7)})
    with pytest.raises(ValueError, match=r"action of robot_0: .* must be 7 finite numbers"):
        env.step({"robot_0": np.array([0.1, np.nan, 0, 0, 0, 0, 0])})
    with pytest.raises(ValueError, match="clock = 'realtime'"):
        parallel_env({**swarm(), "run": {"name": "rt", "clock": "realtime", "ticks": 5}})


def test_task_interface_defaults_give_zero_rewards():
    env = parallel_env(swarm(), task=Task())
    env.reset(seed=0)
    assert set(env.step({})[1].values()) == {0.0}


# ------------------------------------------------------------------ where it runs
async def test_the_env_steps_inside_a_running_event_loop_as_in_a_notebook():
    env = parallel_env(swarm(), task="dispersion")
    obs, _ = env.reset(seed=3)
    obs2, *_ = env.step({a: env.action_space(a).sample() for a in env.agents})
    env.close()
    other = parallel_env(swarm(), task="dispersion")
    assert same(obs, await asyncio.to_thread(lambda: other.reset(seed=3)[0]))


def test_the_documented_examples_run(capsys):
    runpy.run_path(str(EXAMPLES), run_name="rl_tasks")["main"](["--seeds", "1", "--steps", "6"])
    out = capsys.readouterr().out
    assert "repel neighbours" in out and "relay the goal" in out


def test_the_rl_behaviour_without_an_environment_stands_still_in_an_ordinary_run(tmp_path):
    from swarmactors.runs.inprocess import run_inprocess

    sc = line([[0.0, 0.0], [2.0, 0.0]], behaviors=[{"use": "rl"}], ticks=5)
    result = run_inprocess(sc, out=tmp_path)
    assert [r["pose"][:2] for r in result.data["robots"].values()] == [[0.0, 0.0], [2.0, 0.0]]
    assert [r["rl"] for r in result.data["robots"].values()] == [{"observed": 0, "sent": 0, "heard": 0}] * 2


def test_payloads_that_are_not_numbers_are_left_out_and_too_many_are_subsampled_by_the_robots_rng():
    from swarmactors.rl import Observe
    from swarmactors.robot.behavior import Frame

    class Ctx:
        rng = np.random.default_rng(0)

    observer = Observe(("messages",), 0, 2, 2, 0, (), 2)
    bodies = [[0.5, 0.5], ["x", 1], [1, 2, 3], None, [float("nan"), 0.0], [2.0, -3.0]]
    rows = observer._messages(Ctx, [Frame(i, "rl", b, 1, 0.0) for i, b in enumerate(bodies)])
    assert rows.tolist() == [[0.5, 0.5, 1.0], [1.0, -1.0, 1.0]]  # clipped to [-1, 1]
    many = [Frame(i, "rl", [i / 10, 0.0], 1, 0.0) for i in range(6)]
    rows = observer._messages(Ctx, many)
    assert rows[:, 2].tolist() == [1.0, 1.0] and len(set(rows[:, 0].tolist())) == 2

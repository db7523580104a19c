"""The two example tasks of docs/rl.md, each run with hand-written policies: `python docs/examples/rl_tasks.py`.

Needs the ``[rl]`` extra (``pip install -c constraints.txt '.[rl]'``). Prints, for each task and policy, the
mean reward per agent and step over the episodes and the task's metrics at their last step.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from swarmactors.rl import parallel_env

# Dispersion: 20 robots start packed in the middle of a 20 x 20 arena; cover it while staying connected.
DISPERSION = {
    "run": {"name": "rl-dispersion", "ticks": 60, "seed": 0},
    "radio": {"range": 4.0, "latency": 1},
    "world": {"bounds": [[0.0, 0.0], [20.0, 20.0]]},
    "robots": [{"count": 20, "speed": 0.5, "area": [[8.0, 8.0], [12.0, 12.0]], "behaviors": [{"use": "rl"}]}],
}

# Goal relay: 30 robots, connected, in a 12 x 12 area; the goal, at a corner, is sensed (sensing 2) by the few
# robots within 2 of it. The others learn where it is only from messages relayed by their neighbours (range 3).
RELAY = {
    "run": {"name": "rl-relay", "ticks": 60, "seed": 0},
    "radio": {"range": 3.0, "latency": 1},
    "world": {"bounds": [[0.0, 0.0], [12.0, 12.0]],
              "objects": [{"name": "goal", "pos": [11.0, 11.0], "known_by": "sensing"}]},
    "robots": [{"count": 30, "speed": 0.5, "sensing": 2.0, "connected": True, "behaviors": [{"use": "rl"}]}],
}


def still(obs: dict, agent: str, memory: dict) -> np.ndarray:
    """Stand still, say nothing."""
    return np.zeros(2, dtype=np.float32)


def repel(obs: dict, agent: str, memory: dict, reach: float = 3.2) -> np.ndarray:
    """Dispersion: move away from every sensed neighbour closer than ``reach``, the closer the harder."""
    nb = obs["neighbors"]  # rows: range, bearing (in the frame of the velocity command), valid
    push = np.zeros(2)
    for r, b, valid in nb:
        if valid and r < reach:
            push -= (1.0 - r / reach) * np.array([math.cos(b), math.sin(b)])
    norm = np.linalg.norm(push)
    return (push / norm if norm > 1.0 else push).astype(np.float32)


def relay(obs: dict, agent: str, memory: dict, lo: float = 0.0, hi: float = 12.0, talk: bool = True) -> np.ndarray:
    """Goal relay: go to the goal if sensed or heard of (fewest hops first), and tell the neighbours.

    Payload: the goal's world position scaled to [-1, 1] by the arena's size (mission knowledge), and hops / 10.
    """
    pos = obs["pose"][:2]
    gx, gy, known = obs["objects"][0]
    best = memory.get(agent)  # (goal position, hops) this robot learned
    if known:
        best = (pos + np.array([gx, gy]), 0)
    for *payload, valid in obs["messages"]:
        if valid:
            goal = (np.array(payload[:2]) + 1.0) / 2.0 * (hi - lo) + lo
            hops = round(payload[2] * 10) + 1
            if best is None or hops < best[1]:
                best = (goal, hops)
    memory[agent] = best
    action = np.zeros(6, dtype=np.float32)  # vx, vy, payload (3), send
    if best is None:
        action[5] = -1.0
        return action
    goal, hops = best
    way = goal - pos
    dist = np.linalg.norm(way)
    action[:2] = way / dist if dist > 0.5 else 0.0
    action[2:4] = (goal - lo) / (hi - lo) * 2.0 - 1.0
    action[4] = min(hops, 10) / 10
    action[5] = 1.0 if talk else -1.0
    return action


def episode(env, policy, seed: int) -> tuple[float, dict, int]:
    """One episode: the mean reward per agent and step, the last step's task metrics, the steps taken."""
    obs, infos = env.reset(seed=seed)
    memory: dict = {}
    total, count, steps, metrics = 0.0, 0, 0, {}
    while env.agents:
        actions = {a: policy(obs[a], a, memory) for a in env.agents}
        obs, rewards, terminated, truncated, infos = env.step(actions)
        total += sum(rewards.values())
        count += len(rewards)
        steps += 1
        metrics = next(iter(infos.values()))["task"]
    return total / max(count, 1), metrics, steps


def table(name: str, env, policies: dict, seeds: range) -> None:
    print(f"\n{name}: {len(env.possible_agents)} agents, {env.max_steps} steps at most, seeds {seeds.start}.."
          f"{seeds.stop - 1}")
    for label, policy in policies.items():
        runs = [episode(env, policy, s) for s in seeds]
        mean = np.mean([r[0] for r in runs])
        keys = runs[0][1].keys()
        last = ", ".join(f"{k} {np.mean([r[1][k] for r in runs]):.3f}" for k in keys)
        steps = np.mean([r[2] for r in runs])
        print(f"  {label:<28} reward/agent/step {mean:+.4f}   last step: {last}   steps {steps:.1f}")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=5, help="episodes per policy (seeds 0..n-1)")
    ap.add_argument("--steps", type=int, default=None, help="steps per episode (default: the scenario's ticks)")
    args = ap.parse_args(argv)
    seeds = range(args.seeds)
    rng = np.random.default_rng(0)

    env = parallel_env(DISPERSION, task="dispersion", observe=("neighbors",), messages=0, max_steps=args.steps)
    table("dispersion", env, {"stand still": still, "random": lambda o, a, m: rng.uniform(-1, 1, 2),
                              "repel neighbours": repel}, seeds)
    for radio, label in ((None, "loss 0, latency 1"), ({"loss": 0.3, "latency": 3}, "loss 0.3, latency 3")):
        sc = RELAY if radio is None else {**RELAY, "radio": {**RELAY["radio"], **radio}}
        env = parallel_env(sc, task="relay", observe=("pose", "objects", "messages"), messages=4, payload=3,
                           max_steps=args.steps)
        table(f"relay ({label})", env, {
            "go if sensed, no messages": lambda o, a, m: relay(o, a, m, talk=False),
            "relay the goal": relay}, seeds)


if __name__ == "__main__":
    main()

#!/usr/bin/env python
"""Ahmadi & Stone's biconnectivity: our numbers beside the paper's.

    python -m protocols.biconnectivity.experiments.paper [--quick]
        [--only messages|coverage|emulated|loss|loss-repeat|loss-agree]
        [--img docs/img] [--out protocols/biconnectivity/experiments/results/paper.json]

1. **Message counts** (emulator runs, lockstep, no loss): per robot and period, the CR frames sent, relayed
   and received on a ring of 35 robots (the paper: "each robot on average has to deal with 69 messages in
   each time period"), and how they grow on denser graphs: stadium rings of 35 with chord robots, ladders
   (rings with chords), grids and random geometric graphs. Every emulator count is compared with the
   oracle's simple-path count; graphs too large to run are reported from the oracle alone.
2. **Coverage** (the paper's Experimental Results): at most 10 robots, each responsible for a circular
   region of diameter D; neighbours when they can communicate from anywhere in their regions (distance
   between centres + D <= range); cr = range / D = 4 and 2; 100 episodes of random additions and
   removals starting from 5 robots; the mean covered fraction of S (the sum of the regions' areas). The
   episodes use the robots' own placement and removal functions from ``protocols.biconnectivity``
   (``join_position``, ``removal_distance``, ``prox``) with exact positions; the distributed check is
   replaced by its oracle (``paper_biconnected``), which the conformance tests show it equals.
3. **Loss** (the paper assumes reliable links): how often the check's verdict is wrong or missing as the
   per-frame loss p grows (emulator runs), with the paper's rule, repeated fills (R13, ``repeat = 2``) and a
   verdict only after two agreeing periods (R15, ``agree = 2``; ``--only loss-agree``, which also measures
   the three modes' traffic and verdict latency).

Plots go to ``docs/img/biconnectivity-*.png``; all numbers to the JSON file.

The coverage experiment through the emulator as one sweep (a trial = one independent experiment of 100
episodes; the post step writes the mean coverage per cr with its 95 % interval and the measured causes of
the gap, ``coverage.json``), locally or on a Dask cluster:

    swarmactors sweep protocols/biconnectivity/experiments/coverage.toml [--cluster tcp://SCHEDULER:8786] [--trials 12]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import tempfile
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import networkx as nx  # noqa: E402
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]  # the checkout: docs/img, out/

from protocols.biconnectivity.geometry import (  # noqa: E402
    adjacency,
    biconnected,
    join_position,
    prox,
    removal_distance,
)
from protocols.biconnectivity.oracle import expected_counts, paper_biconnected, path_ends  # noqa: E402
from swarmactors.runs.launcher import new_run_id, run_world  # noqa: E402
from swarmactors.runs.scenario import draw_until_connected, resolve_scenario  # noqa: E402
from transport import Endpoints  # noqa: E402

S = 0.9  # neighbour spacing; radio range 1
PAPER = {"messages_35": 69, "coverage_cr4": 0.91, "coverage_cr2": 0.73, "coverage_cr2_min_intersection": 0.75}


# ================================================================ emulator runs
def run_check(positions, n_max: int, loss: float = 0.0, seed: int = 1, budget: int = 10**7, initiator: int = 0,
              repeat: int = 1, agree: int = 1, max_periods: int = 4):
    beh = {"use": "biconnectivity", "N": n_max, "c": 1, "initiator": initiator, "at": 1, "hello": 0,
           "budget": budget}
    if repeat != 1:
        beh["repeat"] = repeat  # R13
    ticks = 6 * n_max + 8
    if agree != 1:
        beh.update(agree=agree, max_periods=max_periods)  # R15
        ticks = max_periods * (6 * n_max + 2) + 8
    sc = {"run": {"name": "bic-exp", "seed": seed, "ticks": ticks, "trace": True},
          "radio": {"range": 1.0, "latency": 1, "loss": loss},
          "robots": [{"positions": [list(map(float, p)) for p in positions], "behaviors": [beh]}]}
    sc = resolve_scenario(sc, "<experiment>")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = asyncio.run(run_world(sc, Path(tmp), Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                                       new_run_id("bic-exp")))
        wall = time.perf_counter() - t0
        graph = result.graph_at(0)
    return result, graph, wall


def ring(n: int) -> np.ndarray:
    radius = S / (2 * math.sin(math.pi / n))
    a = 2 * math.pi * np.arange(n) / n
    return np.stack([radius * np.cos(a), radius * np.sin(a)], axis=1)


def stadium(n: int = 35, chords: int = 0) -> np.ndarray:
    """A ring of n robots drawn as a stadium, optionally with chords.

    Two rows 1.6 apart joined by cap robots at the ends (two on the left when the count is odd), plus
    ``chords`` robots between the rows, each linking the robot above it to the one below it (a chord of
    length 2). With ``chords = 0`` the graph is the ring C_n.
    """
    row = (n - 2 - chords) // 2
    two_left = (n - 2 - chords) % 2 == 1
    bottom = [[S * i, 0.0] for i in range(row)]
    top = [[S * i, 1.6] for i in range(row)]
    caps = ([[-0.45, 0.45], [-0.45, 1.15]] if two_left else [[-0.55, 0.8]]) + [[S * (row - 1) + 0.55, 0.8]]
    mids = [[S * round((k + 1) * (row - 1) / (chords + 1)), 0.8] for k in range(chords)]
    return np.array(bottom + top + caps + mids)


def grid(rows: int, cols: int) -> np.ndarray:
    return np.array([[S * c, S * r] for r in range(rows) for c in range(cols)])


def rgg(n: int, seed: int, density: float = 2.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    try:
        return draw_until_connected(lambda: rng.random((n, 2)) * math.sqrt(n / density), 1.0, attempts=1000)
    except ValueError:
        raise RuntimeError("no connected placement") from None


def graph_of(pts) -> nx.Graph:
    g = nx.Graph()
    g.add_nodes_from(range(len(pts)))
    adj = adjacency(np.asarray(pts), 1.0)
    g.add_edges_from((i, j) for i, nb in enumerate(adj) for j in nb if i < j)
    return g


def messages(quick: bool) -> dict:
    out: dict = {"families": {}}
    emulate_cap = 12_000 if quick else 60_000  # total simple paths we are willing to emulate

    def measure(name: str, pts: np.ndarray, x: float):
        g = graph_of(pts)
        n = len(pts)
        try:
            ends = path_ends(g, limit=5_000_000)
            oracle_sent = float(np.mean(list(ends.values())))
            oracle_recv = float(np.mean([sum(ends[v] for v in g.neighbors(u)) for u in g]))
            total = sum(ends.values())
        except OverflowError:
            oracle_sent = oracle_recv = None
            total = None
        row = {"x": x, "n": n, "edges": g.number_of_edges(), "biconnected": paper_biconnected(g),
               "paths": total, "oracle_mean_sent": oracle_sent, "oracle_mean_received": oracle_recv}
        if total is not None and total <= emulate_cap:
            result, _, wall = run_check(pts, n_max=n)
            per = result["metrics"]["biconnectivity"]["periods"]
            (p,) = per.values()
            row.update(emulated=True, wall_s=round(wall, 2),
                       mean_sent=p["mean_sent"]["CR"], mean_relayed=p["mean_relayed"]["CR"],
                       mean_received=p["mean_received"]["CR"],
                       frames_sent=result["world"]["frames_sent"], deliveries=result["world"]["deliveries"])
            exp = expected_counts(g)
            reps = result.reports("biconnectivity")
            row["equals_oracle"] = all(
                {k: next(iter(reps[v]["periods"].values()))[k][kind] for k in ("sent", "relayed", "received")}
                == exp[v] for v in g if exp[v]["relayed"] for kind in ("CR", "DCR"))
        else:
            row["emulated"] = False
        out["families"].setdefault(name, []).append(row)
        print(f"  {name:22s} n={n:3d} paths={total}  sent/robot={row.get('mean_sent', oracle_sent)}"
              f"  emulated={row['emulated']}", flush=True)

    print("messages per robot and period (CR):")
    for n in ([5, 10, 20, 35] if quick else [5, 10, 15, 20, 25, 30, 35]):
        measure("ring", ring(n), n)
    for c in ([0, 1, 2] if quick else [0, 1, 2, 3, 4]):
        measure("stadium35+chords", stadium(35, c), c)
    for k in ([2, 3, 4, 5, 6] if quick else [2, 3, 4, 5, 6, 7, 8, 9, 10]):
        measure("ladder", np.array([[S * i, 0.0] for i in range(k)] + [[S * i, S] for i in range(k)]), 2 * k)
    for r, c in ([(2, 2), (3, 3), (3, 4)] if quick else [(2, 2), (3, 3), (3, 4), (4, 4), (4, 5)]):
        measure("grid", grid(r, c), r * c)
    for n in ([6, 8, 10] if quick else [6, 8, 10, 12, 14]):
        for seed in range(2 if quick else 4):
            measure("rgg(avg deg ~4)", rgg(n, seed, 2.0), n)
    r35 = out["families"]["ring"][-1]
    out["ring35"] = {"paper": PAPER["messages_35"], "sent": r35["mean_sent"], "relayed": r35["mean_relayed"],
                     "received": r35["mean_received"]}
    return out


def plot_messages(data: dict, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(7.5, 5), dpi=110)
    styles = {"ring": "o-", "ladder": "s-", "grid": "^-", "rgg(avg deg ~4)": "x"}
    for name, rows in data["families"].items():
        if name.startswith("stadium"):
            continue
        xs = [r["n"] for r in rows if r["oracle_mean_sent"]]
        ys = [r["oracle_mean_sent"] for r in rows if r["oracle_mean_sent"]]
        ax.plot(xs, ys, styles.get(name, "o-"), label=f"{name} (oracle)", alpha=0.8)
        em = [(r["n"], r["mean_sent"]) for r in rows if r.get("emulated")]
        if em:
            ax.scatter(*zip(*em, strict=True), s=80, facecolors="none", edgecolors="k", zorder=3)
    st = data["families"].get("stadium35+chords", [])
    for r in st:
        if r["oracle_mean_sent"]:
            ax.scatter([35], [r["oracle_mean_sent"]], marker="D", color="tab:purple", zorder=4)
            ax.annotate(f"stadium, {r['x']} chord{'s' if r['x'] != 1 else ''}", (35, r["oracle_mean_sent"]),
                        textcoords="offset points", xytext=(-8, -3), fontsize=7, ha="right")
    ax.scatter([35], [PAPER["messages_35"]], marker="*", s=260, color="red", zorder=5, label="paper: 69 (35 robots)")
    ax.set_yscale("log")
    ax.set_xlabel("robots n")
    ax.set_ylabel("CR frames sent per robot per period")
    ax.set_title("Stamped-message relay: one frame per simple path\n(circles: measured in the emulator)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


# ================================================================ coverage (the paper's experiment)
def union_area(centres: np.ndarray, rho: float) -> float:
    """Exact area of a union of equal disks: Green's theorem over the boundary arcs no other disk covers."""
    c: list[np.ndarray] = []
    for p in np.asarray(centres, dtype=float):
        if all(np.linalg.norm(p - q) > 1e-12 for q in c):  # coincident disks count once
            c.append(p)
    two_pi = 2 * math.pi
    area = 0.0
    for i, ci in enumerate(c):
        segs = []  # covered angular intervals of circle i, within [0, 2pi)
        for j, cj in enumerate(c):
            d = float(np.linalg.norm(cj - ci))
            if i == j or d >= 2 * rho:
                continue
            phi = math.atan2(cj[1] - ci[1], cj[0] - ci[0]) % two_pi
            alpha = math.acos(d / (2 * rho))
            a, b = phi - alpha, phi + alpha
            if a < 0:
                segs += [(a + two_pi, two_pi), (0.0, b)]
            elif b > two_pi:
                segs += [(a, two_pi), (0.0, b - two_pi)]
            else:
                segs.append((a, b))
        segs.sort()
        free, cur = [], 0.0
        for a, b in segs:
            if a > cur:
                free.append((cur, a))
            cur = max(cur, b)
        if cur < two_pi:
            free.append((cur, two_pi))
        for t1, t2 in free:  # 1/2 * integral of (x dy - y dx) along the arc
            area += 0.5 * (rho * rho * (t2 - t1) + ci[0] * rho * (math.sin(t2) - math.sin(t1))
                           - ci[1] * rho * (math.cos(t2) - math.cos(t1)))
    return area


def structure_fine(pts: np.ndarray, reach: float) -> bool:
    n = len(pts)
    if n <= 1:
        return True
    adj = adjacency(pts, reach)
    if n == 2:
        return 1 in adj[0]
    return biconnected(adj)


def episode_run(cr: float, method: str, seed: int, episodes: int = 100, start: int = 5, n_max: int = 10,
                init: str = "added", d_more_frac: float = 0.05, noise: float = 0.0) -> dict:
    """One experiment: ``episodes`` random additions/removals; coverage after each episode.

    ``init``: the first five robots are ``added`` one by one by the placement rule (our default), or
    ``compact``: a pentagon whose neighbouring centres are D/2 apart (a swarm fresh from its base).
    ``d_more_frac``: the leader's further step d' as a fraction of the neighbour distance.
    ``noise``: standard deviation (in D) of the error on the positions the removal leader computes d from
    (the paper's "approximate" knowledge); the check that follows each move sees the truth.
    """
    D = 1.0
    rho = D / 2
    rng_ = cr * D
    reach = rng_ - D  # centres' distance for two regions to talk from anywhere
    rng = np.random.default_rng(seed)
    d_step, d_more = reach / 100, reach * d_more_frac

    def add(pts):
        if len(pts) == 0:
            return np.zeros((1, 2))
        got = join_position(pts, reach, method=method, rho=rho, rng=rng)
        if got is None:
            raise RuntimeError("no admissible position")
        return np.vstack([pts, got[0]])

    def remove(pts):
        k = int(rng.integers(len(pts)))
        pos = pts[k]
        adj = adjacency(pts, reach)
        nb = sorted(adj[k])
        rest = np.delete(pts, k, axis=0)
        if len(rest) <= 1:
            return rest, 0.0, 0
        idx = [j - (j > k) for j in nb]
        seen = rest[idx] + rng.normal(0.0, noise * D, size=(len(idx), 2)) if noise else rest[idx]
        d = removal_distance(seen, pos, reach, d_step) if len(idx) >= 2 else 0.0
        moved = prox(rest, pos, d)
        total, rounds = d, 1
        while not structure_fine(moved, reach) and rounds < 200:
            moved = prox(moved, pos, d_more)
            total += d_more
            rounds += 1
        extra_rounds.append(rounds - 1)
        return moved, total, rounds

    pts = np.zeros((0, 2))
    if init == "compact":
        a = 2 * math.pi * np.arange(start) / start
        radius = (D / 2) / (2 * math.sin(math.pi / start))
        pts = np.stack([radius * np.cos(a), radius * np.sin(a)], axis=1)
    else:
        for _ in range(start):
            pts = add(pts)
    cover, sizes, moves, broken, states, extra_rounds = [], [], [], 0, [], []
    pooled = [0.0, 0.0]  # sums of covered area and of S over the episodes
    for _ in range(episodes):
        n = len(pts)
        if n >= n_max:
            act = "remove"
        elif n == 0:
            act = "add"
        else:
            act = "add" if rng.random() < 0.5 else "remove"
        if act == "add":
            pts = add(pts)
        else:
            pts, d, rounds = remove(pts)
            moves.append(d)
        if len(pts) and not structure_fine(pts, reach):
            broken += 1
        if len(pts):
            union, total_area = union_area(pts, rho), len(pts) * math.pi * rho * rho
            pooled[0] += union
            pooled[1] += total_area
            cover.append(union / total_area)
            sizes.append(len(pts))
            states.append(pts.tolist())
    return {"mean_coverage": float(np.mean(cover)), "pooled_coverage": pooled[0] / pooled[1],
            "mean_size": float(np.mean(sizes)), "not_biconnected": broken,
            "mean_move": float(np.mean(moves)) if moves else 0.0, "trace": cover, "states": states,
            "extra_rounds": int(sum(extra_rounds))}


def coverage(quick: bool) -> dict:
    seeds = range(5 if quick else 30)
    out = {}
    for cr, method in ((4, "heuristic"), (2, "heuristic"), (2, "min_intersection"), (4, "min_intersection")):
        runs = [episode_run(cr, method, s) for s in seeds]
        vals = [r["mean_coverage"] for r in runs]
        key = f"cr{cr}_{method}"
        out[key] = {"cr": cr, "method": method, "seeds": len(vals), "mean": float(np.mean(vals)),
                    "d_prime_rounds": int(sum(r["extra_rounds"] for r in runs)),
                    "pooled": float(np.mean([r["pooled_coverage"] for r in runs])),
                    "std": float(np.std(vals)), "min": float(np.min(vals)), "max": float(np.max(vals)),
                    "not_biconnected_episodes": int(sum(r["not_biconnected"] for r in runs)),
                    "mean_size": float(np.mean([r["mean_size"] for r in runs])),
                    "example": runs[0]}
        print(f"  coverage cr={cr} {method:17s}: {np.mean(vals):.3f} +- {np.std(vals):.3f} over {len(vals)} runs,"
              f" pooled {out[key]['pooled']:.3f}"
              f" (episodes not biconnected: {out[key]['not_biconnected_episodes']})", flush=True)
    sens = {}
    for cr in (4, 2):
        for label, kw in (("compact start", {"init": "compact"}), ("200 episodes", {"episodes": 200}),
                          ("leader's positions off by sd 0.1 D, d' = 10% of reach", {"noise": 0.1, "d_more_frac": 0.1}),
                          ("leader's positions off by sd 0.3 D, d' = 25% of reach",
                           {"noise": 0.3, "d_more_frac": 0.25})):
            runs = [episode_run(cr, "heuristic", s, **kw) for s in seeds]
            vals = [r["mean_coverage"] for r in runs]
            extra = int(sum(r["extra_rounds"] for r in runs))
            sens[f"cr{cr} heuristic, {label}"] = {"mean": float(np.mean(vals)), "std": float(np.std(vals)),
                                                  "pooled": float(np.mean([r["pooled_coverage"] for r in runs])),
                                                  "d_prime_rounds": extra}
            print(f"  sensitivity cr={cr} heuristic, {label}: {np.mean(vals):.3f} +- {np.std(vals):.3f}"
                  f" (d' rounds: {extra})", flush=True)
    out["sensitivity"] = sens
    out["paper"] = {"cr4_heuristic": PAPER["coverage_cr4"], "cr2_heuristic": PAPER["coverage_cr2"],
                    "cr2_min_intersection": PAPER["coverage_cr2_min_intersection"]}
    return out


def plot_coverage(data: dict, path: Path) -> None:
    fig, (ax, bx, cx) = plt.subplots(1, 3, figsize=(15, 4.6), dpi=110, gridspec_kw={"width_ratios": [1.1, 1.2, 1]})
    keys = ["cr4_heuristic", "cr2_heuristic", "cr2_min_intersection", "cr4_min_intersection"]
    labels = ["cr = 4\nheuristic", "cr = 2\nheuristic", "cr = 2\nmin. intersection", "cr = 4\nmin. intersection"]
    ours = [data[k]["mean"] for k in keys]
    errs = [data[k]["std"] for k in keys]
    paper = [data["paper"].get(k) for k in keys]
    x = np.arange(len(keys))
    ax.bar(x - 0.18, ours, 0.36, yerr=errs, label="ours (mean ± sd over runs)", color="tab:blue")
    ax.bar(x + 0.18, [p if p is not None else 0 for p in paper], 0.36, label="paper", color="tab:orange")
    for i, p in enumerate(paper):
        if p is None:
            ax.text(x[i] + 0.18, 0.02, "n/a", ha="center", fontsize=8)
    ax.set_xticks(x, labels, fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("mean covered fraction of S")
    ax.set_title("Coverage while staying biconnected")
    ax.legend(fontsize=8, loc="lower left")
    for k, colour in (("cr4_heuristic", "tab:blue"), ("cr2_heuristic", "tab:green")):
        ex = data[k]["example"]
        bx.plot(ex["trace"], color=colour, lw=1, label=f"{k.split('_')[0]} (run 0)")
        bx.plot([len(st) / 10 for st in ex["states"]], color=colour, lw=0.6, ls=":")
    bx.set_xlabel("episode")
    bx.set_ylabel("covered fraction of S (solid); robots / 10 (dotted)")
    bx.set_ylim(0, 1.05)
    bx.legend(fontsize=8)
    bx.set_title("One run of 100 episodes")
    ex = data["cr2_heuristic"]["example"]
    k = max(range(len(ex["states"])), key=lambda i: (len(ex["states"][i]), i))
    pts = np.array(ex["states"][k])
    for p in pts:
        cx.add_patch(plt.Circle(p, 0.5, alpha=0.25, color="tab:green"))
    adj = adjacency(pts, 1.0)
    for i, nb in enumerate(adj):
        for j in nb:
            if i < j:
                cx.plot(*zip(pts[i], pts[j], strict=True), color="0.5", lw=0.6)
    cx.scatter(pts[:, 0], pts[:, 1], s=8, color="k")
    cx.set_aspect("equal")
    cx.autoscale()
    cx.set_title(f"cr = 2, run 0, episode {k + 1}: {len(pts)} regions, neighbour links")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


# ================================================================ coverage through the emulator
BUSY_ROLES = ("joiner", "leader", "initiator")


def emulated_experiment(cr: float, method: str, seed: int, episodes: int = 100, start: int = 5, n_max: int = 10,
                        speed: float = 0.25, max_wait: int = 600, budget: int = 20000, graph: str = "structure",
                        repeat: int = 1) -> dict:
    """One experiment of the paper's coverage protocol, run by the robots in the emulator (lockstep).

    Regions of diameter D = 1 (``region`` = 0.5), radio range cr·D. The world starts with robot 0 at the
    origin; a driver on the world's control interface (pause / run_to, ``add``, ``kill``) plays the episodes:
    an addition puts a new robot with ``joiner = true`` at a uniformly random point within half the neighbour
    distance of a random robot (so that it hears someone), and the robot finds its region itself (POS-REQUEST,
    heuristic, approach, settle: R11) moving with the world's kinematics; a removal kills a random robot, and
    its neighbours notice the silence, the lowest-id one leads, MOVE floods travel and the leader's check
    (Algorithm 3) decides whether further moves are needed (R12). The first ``start`` - 1 additions build the
    initial structure and are not episodes. After each action the driver waits until no robot is a joiner, a
    removal leader or a check initiator and none moves (at most ``max_wait`` ticks), then measures coverage
    from the world's true positions: area of the union of the regions over S = n·π(D/2)².
    The robots never see the world's positions except their own; everything else comes from HELLO / POS-REPLY.
    """
    import msgpack

    from transport import unpack

    D, rho = 1.0, 0.5
    reach = cr * D - 2 * rho
    safe = reach * 0.98
    rng = np.random.default_rng(seed + 7919 * int(cr))
    beh = {"use": "biconnectivity", "N": n_max, "c": 1, "hello": 2, "silence": 6, "region": rho, "speed": speed,
           "placement": method, "budget": budget, "graph": graph, "repeat": repeat}
    ticks = (episodes + start) * (max_wait + 40)
    sc = {"run": {"name": "bic-coverage", "seed": seed, "ticks": ticks, "trace": False, "dt": 1.0},
          "radio": {"range": cr * D, "latency": 1},
          "world": {"max_robots": 10 * episodes + 50},  # killed robots keep their ids
          "robots": [{"positions": [[0.0, 0.0]], "speed": speed, "behaviors": [beh]}]}
    sc = resolve_scenario(sc, "<emulated coverage>")
    log: dict = {"cover": [], "sizes": [], "episodes": [], "waits": [], "timeouts": 0, "states": []}
    truth: dict = {"removals": {}, "joins": {}}  # d and the heuristic's best value from the true positions

    def on_open(world, link) -> None:
        clock = world.clock
        clock.run_to(1)  # paused before tick 1, before the world starts: the driver's first action is at tick 1

        async def control(cmd: str, **fields):
            got = unpack(await link.query(world.keys.control, msgpack.packb({"cmd": cmd, **fields})))
            if not got.get("ok"):
                raise RuntimeError(f"control {cmd}: {got}")
            return got

        async def pause_at(t: int) -> None:
            while not (clock.paused and clock.ticks_done == t):  # noqa: ASYNC110 — no per-tick event to await
                await asyncio.sleep(0.0005)

        def alive() -> list[int]:
            return [int(r) for r in np.flatnonzero(world.sim.robots.alive)]

        def busy() -> bool:
            for r in alive():
                st = world.sim.robots.status[r]
                if st.get("role") in BUSY_ROLES or st.get("moving"):
                    return True
            return False

        async def settle(t: int, min_wait: int) -> int:
            t0 = t
            while True:
                t += 4
                await control("run_to", tick=t)
                await pause_at(t)
                if t - t0 >= min_wait and not busy():
                    return t
                if t - t0 > max_wait:
                    log["timeouts"] += 1
                    return t

        def positions() -> np.ndarray:
            return np.array([world.sim.robots.pos[r][:2] for r in alive()], dtype=float).reshape(-1, 2)

        async def drive() -> None:
            t = 1
            await pause_at(t)
            for k in range(episodes + start - 1):
                ids = alive()
                count = len(ids)
                if k < start - 1:
                    act = "add"
                elif count >= n_max:
                    act = "remove"
                elif count == 0:
                    act = "add"
                else:
                    act = "add" if rng.random() < 0.5 else "remove"
                before = positions()
                if act == "add":
                    if len(ids):
                        base = before[int(rng.integers(len(ids)))]
                        ang, rad = rng.uniform(0, 2 * math.pi), safe / 2 * math.sqrt(rng.random())
                        spot = base + rad * np.array([math.cos(ang), math.sin(ang)])
                        b = dict(beh, joiner=True)
                    else:
                        spot, b = np.zeros(2), beh
                    await control("add", args=[{"pos": [float(spot[0]), float(spot[1])], "speed": speed,
                                                "range": cr * D,
                                                "behaviors": [b]}])
                    t = await settle(t, 2)
                    others = before if len(ids) else np.zeros((0, 2))
                    best = join_position(others, safe, method="heuristic") if len(others) else None
                    truth["joins"][len(world.sim.robots.status) - 1] = None if best is None else best[1]
                else:
                    victim = ids[int(rng.integers(len(ids)))]
                    vpos = before[ids.index(victim)]
                    nb = [i for i, r in enumerate(ids) if r != victim
                          and np.linalg.norm(before[i] - vpos) <= reach + 1e-9]
                    truth["removals"][victim] = removal_distance(before[nb], vpos, safe, reach / 100)
                    await control("kill", args=[victim])
                    t = await settle(t, 16)
                log["waits"].append(t)
                if k >= start - 1:
                    pts = positions()
                    log["episodes"].append({"act": act, "tick": t, "n": len(pts)})
                    if len(pts):
                        log["cover"].append(union_area(pts, rho) / (len(pts) * math.pi * rho * rho))
                        log["sizes"].append(len(pts))
                        log["states"].append(pts.round(4).tolist())
            log["ticks"] = t

        async def guarded() -> None:
            try:
                await drive()
            except Exception as exc:  # the run stops; the caller raises
                import traceback

                log["error"] = traceback.format_exc()
                raise exc from None
            finally:
                await control("stop")

        log["task"] = asyncio.get_running_loop().create_task(guarded())

    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = asyncio.run(run_world(sc, Path(tmp), Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                                       new_run_id("bic-coverage"), on_open=on_open))
        wall = time.perf_counter() - t0
        reps = result.reports("biconnectivity")
    if "error" in log:
        raise RuntimeError(f"driver failed: {log['error']}")
    removals = [dict(r, d_true=truth["removals"].get(r["removed"]))
                for rep in reps.values() for r in rep.get("removals", [])]
    joins = [dict(rep["join"], best_true=truth["joins"].get(rid)) for rid, rep in reps.items() if rep.get("join")]
    checks = [ck for rep in reps.values() for ck in rep.get("checks", []) if ck.get("initiator")]
    return {"cr": cr, "method": method, "seed": seed, "mean_coverage": float(np.mean(log["cover"])),
            "pooled_coverage": float(np.sum(np.array(log["cover"]) * np.array(log["sizes"]))
                                     / np.sum(log["sizes"])),
            "mean_size": float(np.mean(log["sizes"])), "ticks": log["ticks"], "wall_s": round(wall, 2),
            "timeouts": log["timeouts"], "cover": log["cover"], "sizes": log["sizes"], "states": log["states"],
            "episodes": log["episodes"], "removals": removals, "joins": joins,
            "check_verdicts": [ck.get("verdict") for ck in checks], 
            "frames_sent": result["world"]["frames_sent"]}


def _emulated_job(args: tuple) -> dict:
    cr, method, seed, episodes = args
    import logging

    logging.getLogger().setLevel(logging.ERROR)
    return emulated_experiment(cr, method, seed, episodes=episodes)


def coverage_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One experiment of ``coverage.toml`` (beside this module): cr, seed ``trial + 1`` (as emulated_coverage)."""
    import logging

    logging.getLogger().setLevel(logging.ERROR)
    return emulated_experiment(float(params["cr"]), params.get("method", "heuristic"), trial + 1,
                               episodes=int(params["episodes"]))


def coverage_figures(csv_path: Path, out_dir: Path) -> list[Path]:
    """The post step: per cr, the summary of ``summarise_emulated`` beside the paper's number (``coverage.json``)."""
    from swarmactors.tools.sweep import returned_values

    runs = returned_values(csv_path)
    out = {f"cr{int(cr)}_{m}": summarise_emulated([r for r in runs if r["cr"] == cr and r["method"] == m])
           for cr, m in sorted({(r["cr"], r["method"]) for r in runs})}
    out["paper"] = {"cr4_heuristic": PAPER["coverage_cr4"], "cr2_heuristic": PAPER["coverage_cr2"],
                    "cr2_min_intersection": PAPER["coverage_cr2_min_intersection"]}
    path = Path(out_dir) / "coverage.json"
    path.write_text(json.dumps(out, indent=1, default=float))
    return [path]


def ci95(vals) -> tuple[float, float]:
    """Mean and the half-width of its 95 % interval (Student's t over independent experiments)."""
    from scipy import stats

    v = np.asarray(vals, dtype=float)
    if len(v) < 2:
        return float(v.mean()), float("nan")
    return float(v.mean()), float(stats.t.ppf(0.975, len(v) - 1) * v.std(ddof=1) / math.sqrt(len(v)))


def emulated_coverage(quick: bool, reps: dict[float, int], jobs: int = 2, episodes: int = 100,
                      runs_file: Path | None = None, run: bool = True, method: str = "heuristic") -> dict:
    """The coverage experiment through the emulator: R independent experiments per cr, each ``episodes`` long.

    The experiments of the cr values are interleaved; each finished one is appended to ``runs_file`` (JSON
    lines) at once, and runs already there are reused, so an interrupted sweep resumes where it stopped.
    """
    from concurrent.futures import ProcessPoolExecutor, as_completed

    eps = 20 if quick else episodes
    todo = [(float(cr), method, s, eps) for s in range(1, max(reps.values()) + 1) for cr, r in reps.items()
            if s <= (2 if quick else r)]
    done: dict[tuple, dict] = {}
    if runs_file is not None and runs_file.exists():
        for line in runs_file.read_text().splitlines():
            got = json.loads(line)
            done[(got["cr"], got["method"], got["seed"], got["episodes_asked"])] = got
    t0 = time.perf_counter()
    with ProcessPoolExecutor(jobs) as pool:
        futures = {pool.submit(_emulated_job, a): a for a in todo if a not in done and run}
        for fut in as_completed(futures):
            got = dict(fut.result(), episodes_asked=futures[fut][3])
            done[futures[fut]] = got
            print(f"  cr={got['cr']} seed={got['seed']}: {got['mean_coverage']:.3f} ({got['wall_s']} s)", flush=True)
            if runs_file is not None:
                with runs_file.open("a") as f:
                    f.write(json.dumps(got, default=float) + "\n")
    out: dict = {"wall_s": round(time.perf_counter() - t0, 1)}
    for cr in reps:
        runs = [done[a] for a in todo if a[0] == float(cr) and a in done]
        out[f"cr{int(cr)}_{method}"] = summarise_emulated(runs)
    out["paper"] = {"cr4_heuristic": PAPER["coverage_cr4"], "cr2_heuristic": PAPER["coverage_cr2"],
                    "cr2_min_intersection": PAPER["coverage_cr2_min_intersection"]}
    return out


def summarise_emulated(runs: list[dict]) -> dict:
    """Mean coverage with its 95 % interval over experiments, and what explains the gap (measured)."""
    mean, half = ci95([x["mean_coverage"] for x in runs])
    rem = [x for run in runs for x in run["removals"]]
    d_off = [abs(x["d"][0] - x["d_true"]) for x in rem if x.get("d_true") is not None and x["d"]]
    jv = [(j["value"], j["best_true"]) for run in runs for j in run["joins"]]
    small = [x for x in rem if len(x["neighbours"]) <= 2]
    by_n: dict = {}
    for run in runs:
        for c, n in zip(run["cover"], run["sizes"], strict=True):
            by_n.setdefault(n, []).append(c)
    o = {
        "cr": runs[0]["cr"], "experiments": len(runs), "episodes": len(runs[0]["cover"]), "mean": mean,
        "ci95": half, "per_experiment": [x["mean_coverage"] for x in runs],
        "pooled": float(np.mean([x["pooled_coverage"] for x in runs])),
        "mean_size": float(np.mean([x["mean_size"] for x in runs])),
        "ticks": int(sum(x["ticks"] for x in runs)), "run_wall_s": float(sum(x["wall_s"] for x in runs)),
        "timeouts": int(sum(x["timeouts"] for x in runs)),
        "removals": len(rem), "d_prime_rounds": int(sum(x["rounds"] - 1 for x in rem)),
        "removals_with_d_prime": int(sum(x["rounds"] > 1 for x in rem)),
        "removals_two_or_fewer_exneighbours": len(small),
        "d_prime_rounds_two_or_fewer": int(sum(x["rounds"] - 1 for x in small)),
        "verdicts": {str(v): int(sum(x["verdict"] == v for x in rem)) for v in (True, False, None)},
        "d_error_max": float(max(d_off)) if d_off else 0.0,
        "d_error_mean": float(np.mean(d_off)) if d_off else 0.0,
        "mean_d": float(np.mean([x["d"][0] for x in rem if x["d"]])) if rem else 0.0,
        "join_value_ratio_min": float(min((a / b for a, b in jv if b), default=float("nan"))),
        "join_value_ratio_mean": float(np.mean([a / b for a, b in jv if b])) if jv else float("nan"),
        "coverage_by_size": {str(n): [float(np.mean(v)), len(v)] for n, v in sorted(by_n.items())},
        "frames_sent": int(sum(x["frames_sent"] for x in runs)),
        "example": {k: runs[0][k] for k in ("cover", "sizes", "states")},
    }
    print(f"  emulated cr={o['cr']}: {mean:.3f} +- {half:.3f} (95 %) over {len(runs)} experiments; d' rounds "
          f"{o['d_prime_rounds']} ({o['d_prime_rounds_two_or_fewer']} with <= 2 ex-neighbours); "
          f"|d - d_true| max {o['d_error_max']:.3f}; verdicts {o['verdicts']}", flush=True)
    return o


# ================================================================ loss
def loss_sweep(quick: bool, repeat: int = 1, agree: int = 1, ps: list[float] | None = None) -> dict:
    """Verdicts of every check-running robot under loss, with their cost.

    Cost per row: ``frames_per_robot`` (every frame the robots sent, all kinds, per robot and run) and
    ``latency`` (mean time from the request to a robot's verdict, over the robots that decided; ticks).
    """
    graphs = {
        "ring8": (ring(8), True),
        "ladder2x4": (np.array([[S * i, 0.0] for i in range(4)] + [[S * i, S] for i in range(4)]), True),
        "bowtie": (np.array([[0.0, 0.0], [-0.8, 0.45], [-0.8, -0.45], [0.8, 0.45], [0.8, -0.45]]), False),
        "path5": (np.array([[S * i, 0.0] for i in range(5)]), False),
    }
    ps = ps or [0.0, 0.01, 0.05, 0.1, 0.2, 0.3, 0.5]
    seeds = range(3 if quick else 10)
    rows = []
    for p in ps:
        agg = {"p": p, "checks": 0, "correct": 0, "wrong": 0, "missing": 0, "wrong_true": 0, "wrong_false": 0,
               "checks_on_biconnected": 0, "wrong_on_biconnected": 0, "missing_on_biconnected": 0,
               "checks_on_not_biconnected": 0, "wrong_on_not_biconnected": 0, "missing_on_not_biconnected": 0}
        frames, latency, periods = [], [], []
        for pts, truth in graphs.values():
            for seed in seeds:
                result, _, _ = run_check(pts, n_max=max(len(pts), 3), loss=p, seed=seed, repeat=repeat,
                                         agree=agree)
                assert result["stop_reason"] is None
                frames.append(result["world"]["frames_sent"] / len(pts))
                cls = "biconnected" if truth else "not_biconnected"
                for rep in result.reports("biconnectivity").values():
                    for ck in rep["checks"]:
                        if ck["decided"] is not None and ck["verdict"] is not None:
                            latency.append(ck["decided"] - ck["requested"])
                        if "rounds" in ck:
                            periods.append(len(ck["rounds"]))
                        agg["checks"] += 1
                        agg[f"checks_on_{cls}"] += 1
                        if ck["verdict"] is None:
                            agg["missing"] += 1
                            agg[f"missing_on_{cls}"] += 1
                        elif ck["verdict"] is truth:
                            agg["correct"] += 1
                        else:
                            agg["wrong"] += 1
                            agg[f"wrong_on_{cls}"] += 1
                            agg["wrong_true" if ck["verdict"] else "wrong_false"] += 1
        agg["frames_per_robot"] = round(float(np.mean(frames)), 1)
        agg["latency"] = round(float(np.mean(latency)), 1) if latency else None
        if periods:
            agg["periods"] = round(float(np.mean(periods)), 2)
        rows.append(agg)
        print(f"  loss p={p:.2f}: {agg}", flush=True)
    return {"graphs": list(graphs), "seeds": len(seeds), "rows": rows, "repeat": repeat, "agree": agree}


def plot_loss(data: dict, path: Path, repeat2: dict | None = None, agree2: dict | None = None) -> None:
    """False verdicts and timeouts against the loss p; with R13 ``repeat2`` (dashed) and R15 ``agree2`` (dotted)."""
    fig, ax = plt.subplots(figsize=(7.5, 4.8), dpi=110)
    for d, ls, tag in ((data, "-", "paper (repeat = 1)"), (repeat2, "--", "repeat = 2"),
                       (agree2, ":", "agree = 2")):
        if d is None:
            continue
        rows = d["rows"]
        p = [r["p"] for r in rows]
        for cls, colour in (("biconnected", "tab:blue"), ("not_biconnected", "tab:red")):
            n = [max(1, r[f"checks_on_{cls}"]) for r in rows]
            label = cls.replace("_", " ")
            ax.plot(p, [r[f"wrong_on_{cls}"] / k for r, k in zip(rows, n, strict=True)], "o" + ls, color=colour,
                    label=f"wrong verdict, {label} graphs, {tag}")
            ax.plot(p, [r[f"missing_on_{cls}"] / k for r, k in zip(rows, n, strict=True)], "x" + ls, color=colour,
                    alpha=0.5, label=f"no verdict (timeout; agree: no agreement), {label} graphs, {tag}")
    ax.set_xlabel("per-frame loss p")
    ax.set_ylabel("fraction of check-running robots")
    ax.set_title(f"The check under loss ({', '.join(data['graphs'])}; {data['seeds']} seeds)", fontsize=10)
    ax.legend(fontsize=6.5)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def replot_messages(results: Path, out_dir: Path) -> list[Path]:
    """The messages figure re-drawn from the saved ``paper.json``."""
    path = Path(out_dir) / "biconnectivity-messages.png"
    plot_messages(json.loads(Path(results).read_text())["messages"], path)
    return [path]


def replot_coverage(results: Path, out_dir: Path) -> list[Path]:
    """The coverage figure (oracle-level experiments) re-drawn from the saved ``paper.json``."""
    path = Path(out_dir) / "biconnectivity-coverage.png"
    plot_coverage(json.loads(Path(results).read_text())["coverage"], path)
    return [path]


def replot_loss(results: Path, out_dir: Path) -> list[Path]:
    """The check under loss re-drawn from the saved ``paper.json``."""
    data = json.loads(Path(results).read_text())
    path = Path(out_dir) / "biconnectivity-loss.png"
    plot_loss(data["loss"], path, data.get("loss_repeat2"), data.get("loss_agree2"))
    return [path]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer graphs, seeds and runs")
    ap.add_argument("--img", default=str(ROOT / "docs" / "img"))
    ap.add_argument("--out", default=str(HERE / "results" / "paper.json"))
    ap.add_argument("--only", choices=["messages", "coverage", "emulated", "loss", "loss-repeat", "loss-agree"],
                    default=None)
    ap.add_argument("--reps", default="2:16,4:8", help="emulated coverage: experiments per cr, 'cr:R,cr:R'")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes for the emulated coverage")
    ap.add_argument("--method", default="heuristic", choices=["heuristic", "min_intersection"],
                    help="emulated coverage: the joiner's placement (results under emulated_coverage_<method> "
                         "unless heuristic)")
    ap.add_argument("--aggregate", action="store_true",
                    help="emulated coverage: summarise the finished experiments in --runs, run nothing")
    ap.add_argument("--runs", default=str(ROOT / "out" / "biconnectivity_emulated_runs.jsonl"),
                    help="emulated coverage: JSON lines of finished experiments, reused when resuming")
    args = ap.parse_args()
    img = Path(args.img)
    img.mkdir(parents=True, exist_ok=True)
    out_path = Path(args.out)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    data = json.loads(out_path.read_text()) if out_path.exists() else {}
    t0 = time.perf_counter()
    if args.only in (None, "messages"):
        data["messages"] = messages(args.quick)
        plot_messages(data["messages"], img / "biconnectivity-messages.png")
    if args.only in (None, "coverage"):
        print("coverage (cr = range / region diameter):")
        data["coverage"] = coverage(args.quick)
        plot_coverage(data["coverage"], img / "biconnectivity-coverage.png")
    if args.only in (None, "emulated"):
        print("coverage through the emulator:")
        reps = {float(a): int(b) for a, b in (x.split(":") for x in args.reps.split(","))}
        key = "emulated_coverage" + ("" if args.method == "heuristic" else f"_{args.method}")
        data[key] = emulated_coverage(args.quick, reps, args.jobs, runs_file=Path(args.runs) if args.runs else None,
                                      run=not args.aggregate, method=args.method)
    if args.only in (None, "loss"):
        print("the check under loss:")
        data["loss"] = loss_sweep(args.quick)
    if args.only in (None, "loss", "loss-repeat"):
        print("the check under loss, initiating messages sent twice (repeat = 2, R13):")
        data["loss_repeat2"] = loss_sweep(args.quick, repeat=2)
    if args.only in (None, "loss-agree"):
        ps = [0.0, 0.05, 0.1, 0.2]
        print("the check under loss, a verdict only after two agreeing periods (agree = 2, R15):")
        data["loss_agree2"] = loss_sweep(args.quick, agree=2, ps=ps)
        print("the cost of the paper's check and of repeat = 2 at the same losses:")
        data["loss_cost"] = {f"repeat{r}": loss_sweep(args.quick, repeat=r, ps=ps) for r in (1, 2)}
    if "loss" in data:
        plot_loss(data["loss"], img / "biconnectivity-loss.png", data.get("loss_repeat2"), data.get("loss_agree2"))
    data.pop("wall_s", None)
    data["quick"] = args.quick
    data[f"wall_s_{args.only or 'all'}"] = round(time.perf_counter() - t0, 1)
    out_path.write_text(json.dumps(data, indent=1, default=float))
    print(f"wrote {out_path} and {img}/biconnectivity-*.png in {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()

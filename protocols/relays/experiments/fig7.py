"""Swarm Relays, Fig. 7 reduced (002 Sec. V, scalability and random failures) on generated mazes.

The paper's arenas are three Moving AI maps (dragon age: arena 49 x 49, den203d 93 x 77, arena2 281 x 209
cells of 1 m, as the reference code's loop functions build them: one 1 m box a blocked cell) with 25, 60
and 100 robots, d_s / d_c / d_b = 9.5 / 9.7 / 10 m and v_max = 0.1 m/s. We do not ship those maps; each arena
here is the world's generated perfect maze of about the same size (``swarmactors.runs.maps.maze``, corridors 2
cells and walls 1 cell of side ``cell`` metres):

    arena 1: 3 x 3 maze cells (seed 5), cell 4.9 m    -> 49 x 49 m   (corridors 9.8 m), path 51 m, 25 robots
    arena 2: 4 x 3 maze cells (seed 0), cell 93/13 m  -> 93 x 72 m   (corridors 14 m),  path 112 m, 60 robots
    arena 3: 4 x 3 maze cells (seed 2), cell 281/13 m -> 281 x 216 m (corridors 43 m),  path 256 m, 100 robots

(maze seeds chosen so that three chains fit in the robots: 3 ceil(path / d_s) + 1 <= N; ground robots only,
unless ``hetero`` = 1: 5 of the N robots flying and a low wall only flying robots cross, see ``heterogeneous``
and ``fence``).

The root stands at the centre of the top-left maze cell, the target at the bottom-right one's; the other
robots on a 0.5 m grid around the root (jittered by up to 0.1 m per trial). Radio: range Z = 10.5 m (the
issue), the distance model with delta = 0.15 m, no occlusion. One tick is dt = 1 s: a robot then moves
0.1 m a tick, as at the small scale (0.5 m/s x 0.2 s), so a link of d_s is 95 ticks either way; the
recruiting slot is 3 s (3 ticks). Planning at resolution R = 1 m with a clearance of 1 m.

Random failures (Fig. 7 bottom): the paper fails a robot at every control step (ARGoS: 0.1 s) with
probability p = 0.0005, bounded by a fraction F of the robots. Here each robot but the root draws its
failure tick from the same law per 1 s tick (1 - (1 - p)^10), counted from the close of the elections
(1 + C_n bid_time + plan_time s: a robot that dies while it holds the election's lowest bid leaves its
target without a worker, which neither the paper nor our protocol handles), and the first floor(F N) of
them are killed.

Metrics per run: build time = the last chain's worker within tolerance of the target - the tick the target
was written (s); traversal time = the longest planned path / v_max; time factor = build / traversal (>= 1);
time ratio = traversal / build (its inverse, <= 1; docs/protocols/relays.md says why we report it beside
the paper's 0.106 and 0.102).

    swarmactors sweep protocols/relays/experiments/fig7.toml --workers 2
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np

from protocols.relays.suite import maze_scenario

ARENAS = {  # maze cells, cell side (m), maze seed, robots
    1: {"cols": 3, "rows": 3, "cell": 4.9, "maze_seed": 5, "robots": 25},
    2: {"cols": 4, "rows": 3, "cell": 93 / 13, "maze_seed": 0, "robots": 60},
    3: {"cols": 4, "rows": 3, "cell": 281 / 13, "maze_seed": 2, "robots": 100},
}
LARGE = {"ds": 9.5, "dc": 9.7, "db": 10.0, "vmax": 0.1, "recruit_time": 3.0, "join_time": 30.0, "resolution": 1.0,
         "clearance": 1.0, "budget": 400000}
DT, RANGE, P_STEP, STEP = 1.0, 10.5, 0.0005, 0.1


def failures(n: int, fraction: float, start: int, ticks: int, seed: int) -> list[tuple[int, list[int]]]:
    """Kill events: robots 1..n-1 fail at geometric ticks after ``start``; the first floor(F n) are kept."""
    if fraction <= 0:
        return []
    rng = np.random.default_rng([seed, n, 7])
    p = 1 - (1 - P_STEP) ** (DT / STEP)
    at = start + rng.geometric(p, size=n - 1)
    order = sorted(range(1, n), key=lambda i: (at[i - 1], i))[: int(math.floor(fraction * n))]
    events: dict[int, list[int]] = {}
    for i in order:
        if at[i - 1] < ticks:
            events.setdefault(int(at[i - 1]), []).append(i)
    return sorted(events.items())


def heterogeneous(sc: dict, flying: int = 5, wall_x: tuple[float, float] = (32.3, 33.3), altitude: float = 0.7,
                  wall_top: float = 0.5, arena: int = 1) -> dict:
    """An arena with ``flying`` flying robots and a low wall only flying robots cross (the paper's arena 1 case).

    Arena 1 (the paper's 20 ground + 5 flying robots): the generated maze has one corridor to the target (down
    the left column, then along the bottom row); a wall ``wall_top`` high across that row at x in ``wall_x`` (5.9 m
    before the target; the airborne part of pi, from ``clearance`` before it, is 8.1 m, less than d_s) stops
    ground robots, so every chain's worker must be a flying robot (at ``altitude``, above the wall) and the rest of
    the chain can be ground robots: C_n = 3 chains take 3 of the 5 flying robots. Arenas 2 and 3 (ours: the paper
    ran them with ground robots only): the same number of flying robots among the N, and the same low wall, 1 m
    thick and 5.9 m from the target, across every open side of the target's maze cell (``fence``). The world
    becomes 3-D (z from 0 to 2 m); the flying robots are the ``flying`` robots placed farthest from the root, so
    a ground robot is usually elected first and hands over (Fig. 4).
    """
    group = sc["robots"][0]
    pos = group["positions"]
    cut = len(pos) - flying
    beh = group["behaviors"][0]
    common = {k: v for k, v in group.items() if k not in ("positions", "behaviors")}
    sc["robots"] = [{**common, "positions": [p + [0.0] for p in pos[:cut]], "behaviors": [beh]},
                    {**common, "positions": [p + [altitude] for p in pos[cut:]], "kind": "flying",
                     "altitude": [altitude, altitude], "behaviors": [{**beh, "kind": "flying"}]}]
    a = ARENAS[arena]
    width, height = a["cell"] * (a["cols"] * 3 + 1), a["cell"] * (a["rows"] * 3 + 1)
    boxes = [[[wall_x[0], 0.0], [wall_x[1], height]]] if arena == 1 else fence(arena)
    sc["world"].update(dims=3, bounds=[[0.0, 0.0, 0.0], [width, height, 2.0]],
                       obstacles=[{"box": box, "z": [0.0, wall_top]} for box in boxes])
    return sc


def fence(arena: int, gap: float = 5.9, thick: float = 1.0, overlap: float = 0.5) -> list[list[list[float]]]:
    """The low wall of arenas 2 and 3 (``heterogeneous``): boxes ``thick`` wide, ``gap`` from the target.

    One box across each open side of the target's maze cell (the bottom-right one: its left side, towards the
    cell before it in the bottom row, and its top side, towards the cell above), spanning the cell's room; when
    both sides are open the two boxes meet at the corner (gap + thick from the target on both axes), so no
    ground path reaches the target. A closed side's end runs ``overlap`` into the maze wall.
    """
    from swarmactors.runs.maps import maze

    a = ARENAS[arena]
    plan = maze(a["cols"], a["rows"], seed=a["maze_seed"])
    cell, c, r = a["cell"], a["cols"] - 1, a["rows"] - 1
    h = len(plan)
    x0, y1 = (1 + 3 * c) * cell, (h - 1 - 3 * r) * cell  # the room: grid columns 3c+1..3c+2, rows 3r+1..3r+2
    x1, y0 = x0 + 2 * cell, y1 - 2 * cell
    tx, ty = (x0 + x1) / 2, (y0 + y1) / 2
    left, top = plan[1 + 3 * r][3 * c] == ".", plan[3 * r][1 + 3 * c] == "."
    near, far = gap, gap + thick
    boxes = []
    if top:
        boxes.append([[tx - far if left else x0 - overlap, ty + near], [x1 + overlap, ty + far]])
    if left:
        boxes.append([[tx - far, y0 - overlap], [tx - near, ty + far if top else y1 + overlap]])
    return boxes


def scenario(arena: int, chains: int, fraction: float, trial: int, ticks: int, hetero: bool = False) -> dict:
    a = ARENAS[arena]
    sc = maze_scenario(a["robots"], a["cols"], a["rows"], maze_seed=a["maze_seed"], cell=a["cell"], ticks=ticks,
                       seed=trial + 1, dt=DT, radio_range=RANGE, chains_per_target=chains, **LARGE,
                       checks=[{"use": "relays.reached", "slack": 100.0}, {"use": "relays.links_within_db"}])
    rng = np.random.default_rng([trial, arena, 70])
    pos = sc["robots"][0]["positions"]
    for p in pos[1:]:
        p[0], p[1] = round(p[0] + rng.uniform(-0.1, 0.1), 4), round(p[1] + rng.uniform(-0.1, 0.1), 4)
    start = 1 + round((chains * 10.0 + 2.0) / DT)
    kills = failures(a["robots"], fraction, start, ticks, trial)
    if kills:
        sc["events"] = [{"at": at, "kill": ids} for at, ids in kills]
    if hetero:
        sc = heterogeneous(sc, arena=arena)
    return sc


def run_one(arena: int, chains: int, fraction: float, trial: int, ticks: int, hetero: bool = False) -> dict:
    from swarmactors.runs.launcher import run

    sc = scenario(arena, chains, fraction, trial, ticks, hetero)
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        r = run(sc, out=tmp)
        reached = [c for c in r.checks if c["name"] == "relays.reached"]
        reports = r.reports("relays")
    paths = [rep["path"] for rep in reports.values() if rep.get("path")]
    longest = max((sum(math.dist(p[:2], q[:2]) for p, q in zip(x, x[1:], strict=False)) for x in paths),
                  default=None)
    done = [c["value"] for c in reached if c["value"] is not None]
    all_reached = len(done) == chains and all(c["passed"] for c in reached)
    flying = sum(len(g["positions"]) for g in sc["robots"] if g.get("kind") == "flying")
    workers = [rep for rep in reports.values() if rep.get("path")]
    out = {"arena": arena, "chains": chains, "F": fraction, "trial": trial, "robots": ARENAS[arena]["robots"],
           "hetero": int(hetero), "flying": flying, "worker_kinds": sorted(rep.get("kind") for rep in workers),
           "killed": sum(len(e["kill"]) for e in sc.get("events", [])), "ticks": ticks,
           "wall_s": round(time.time() - t0, 1), "reached": len(done), "all_reached": all_reached,
           "links_ok": all(c["passed"] for c in r.checks if c["name"] == "relays.links_within_db"),
           "longest_link_m": next((c["value"] for c in r.checks if c["name"] == "relays.links_within_db"), None),
           "path_m": None if longest is None else round(longest, 2),
           "reached_s": sorted(done)}  # each chain's first tick with its worker at the target
    if all_reached and longest:
        build = max(done) - DT  # the root writes the target at tick 1
        traversal = longest / LARGE["vmax"]
        out.update(build_s=round(build, 1), traversal_s=round(traversal, 1),
                   time_factor=round(build / traversal, 4), time_ratio=round(traversal / build, 4))
    return out


def sweep_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One run of ``fig7.toml`` (beside this module): arena, chains (C_n) and failure bound F from the grid."""
    arena, chains, fraction = int(params["arena"]), int(params["chains"]), float(params["F"])
    ticks = int(params.get("ticks", {1: 1500, 2: 2200, 3: 5000}[arena]))
    return run_one(arena, chains, fraction, trial, ticks, bool(int(params.get("hetero", 0))))


def sweep_figures(csv_path: Path, out_dir: Path) -> list[Path]:
    """The sweep's post step: the summary table (printed) and Fig. 7's two panels as relays_fig7.png."""
    from swarmactors.tools.sweep import returned_values

    rows = returned_values(csv_path)
    summarise(rows)
    path = Path(out_dir) / "relays_fig7.png"
    plot(rows, path)
    return [path]


def summarise(rows: list[dict]) -> None:
    """Per cell (arena, C_n, F, hetero): runs, reached, median build time, traversal, time factor and time ratio."""
    cells = sorted({(r["arena"], r["chains"], r["F"], r.get("hetero", 0)) for r in rows})
    for cell in cells:
        rs = [r for r in rows if (r["arena"], r["chains"], r["F"], r.get("hetero", 0)) == cell]
        ok = [r for r in rs if r.get("time_factor") is not None]
        med = {k: float(np.median([r[k] for r in ok])) if ok else math.nan
               for k in ("build_s", "traversal_s", "time_factor", "time_ratio")}
        name = f"arena {cell[0]}{' hetero' if cell[3] else ''} C_n={cell[1]} F={cell[2]}"
        print(f"{name}: {len(ok)}/{len(rs)} reached; build {med['build_s']:.0f} s, "
              f"traversal {med['traversal_s']:.0f} s, time factor {med['time_factor']:.3f}, "
              f"time ratio {med['time_ratio']:.3f}; killed {[r['killed'] for r in rs]}; "
              f"wall {sum(r['wall_s'] for r in rs):.0f} s")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(13, 4))
    ax = axes[0]
    for arena, hetero in sorted({(r["arena"], r.get("hetero", 0)) for r in rows}):
        for k, chains in enumerate(sorted({r["chains"] for r in rows})):
            cell = (arena, chains, 0.0, hetero)
            rs = [r for r in rows if (r["arena"], r["chains"], r["F"], r.get("hetero", 0)) == cell and r.get("build_s")]
            x = arena + 0.45 * hetero + (k - 1) * 0.12
            ax.scatter([x] * len(rs), [r["build_s"] for r in rs], color=f"C{k}", marker="^" if hetero else "o",
                       label=None if arena > 1 or hetero else f"C_n = {chains}")
            if rs:
                ax.scatter([x], [rs[0]["traversal_s"]], color="k", marker="_", s=200)
    ax.set_xlabel("arena (triangles: with 5 flying robots; bars: traversal time)")
    ax.set_ylabel("time to build (s)")
    ax.set_title("Fig. 7 top, reduced (ours)")
    ax.legend(fontsize=8)
    ax = axes[1]
    arena1 = [r for r in rows if r["arena"] == 1 and not r.get("hetero")]
    top = max((r["build_s"] for r in arena1 if r.get("build_s")), default=1.0) * 1.04
    for k, chains in enumerate(sorted({r["chains"] for r in arena1})):
        rs = [r for r in arena1 if r["chains"] == chains]
        if len({r["F"] for r in rs}) < 2:
            continue
        dx = (k - 1) * 0.012  # the cells of C_n = 1, 2, 3 side by side
        built = [r for r in rs if r.get("build_s")]
        ax.scatter([r["F"] + dx for r in built], [r["build_s"] for r in built], s=12, color=f"C{k}",
                   label=f"arena 1, C_n = {chains}")
        for f in sorted({r["F"] for r in rs}):  # a cross per cell with runs that never built, and how many
            never = [r for r in rs if r["F"] == f and not r.get("build_s")]
            if never:
                ax.scatter([f + dx], [top], marker="x", color=f"C{k}")
                ax.annotate(str(len(never)), (f + dx, top), textcoords="offset points", xytext=(0, 5 + 8 * k),
                            ha="center", fontsize=7, color=f"C{k}")
    ax.scatter([], [], marker="x", color="0.4", label="runs not built by the end (count above)")
    ax.set_ylim(top=top * 1.1)
    ax.set_xlabel("failure bound F")
    ax.set_ylabel("time to build (s)")
    ax.set_title("Fig. 7 bottom, arena 1 (ours)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    import json
    import sys

    a, c, f, t, ticks = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
    hetero = len(sys.argv) > 6 and bool(int(sys.argv[6]))
    print(json.dumps(run_one(a, c, f, t, ticks, hetero)))

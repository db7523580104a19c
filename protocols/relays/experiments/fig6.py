"""Swarm Relays, Fig. 6 (002 Sec. V): time factor in 12 conditions, and recovery after consecutive failures.

Time factor (middle/top): 2-4 targets on a circle of radius 10 m around the root, with and without a
C-shaped obstacle on each target's ray (5 m out, its cup open towards the root), with and without WP
prediction (without it, ``ask`` = "stretched" or "plan": when the head asks for a robot, and ``route`` = "first" or
"base": where its request stops, R5). Time factor =
(tick the last worker reaches its target - tick the targets are written) * dt,
divided by the traversal time (the longest planned path / v_max). N = 9 T + 4 robots (9 per chain, 4 spare),
clustered at the root with a random jitter per run (seed).

Failure ratio (bottom): one target 10 m away (7 links, 6 networkers); after the chain is built, f = 1..5
consecutive networkers (counted from the worker's parent) are killed; recovery time = relays.healed's value
(kill -> chain whole again, the 5 s link-failure time included), and its ratio to the traversal time.

    python -m protocols.relays.experiments.fig6 --runs 4 --workers 2    # results/fig6.json
    python -m protocols.relays.experiments.fig6 --plot protocols/relays/experiments/results/fig6.json

The same experiment as two sweeps (one trial a run; a failure trial builds its chain first, then kills f
networkers), locally or on a Dask cluster; the post step draws relays_fig6.png beside trials.csv:

    swarmactors sweep protocols/relays/experiments/fig6.toml [--cluster tcp://SCHEDULER:8786] [--trials 4]
    swarmactors sweep protocols/relays/experiments/fig6-failures.toml [--cluster ...]
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import re
import tempfile
import time
from pathlib import Path

import numpy as np

from protocols.relays.suite import relays_scenario

RADIUS = 10.0


def failure_checks() -> list[dict]:
    """A Fig. 6 bottom run's checks, a new list for each scenario.

    Recovery time, the worker at its target, and every chain whole at every tick outside the 60 s after the kill
    (relays.connected's default healing window).
    """
    return [{"use": "relays.healed"}, {"use": "relays.reached", "slack": 100.0}, {"use": "relays.connected"}]


def c_shape(center: list[float], angle: float, size: float = 3.0, thickness: float = 0.4) -> list[dict]:
    """A C of outer side ``size`` centred at ``center``, its open side facing the direction angle + pi."""
    ca, sa = math.cos(angle), math.sin(angle)

    def box(x0, y0, x1, y1):  # in the C's frame (x along the ray), rotated into the world
        pts = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        return {"xy": [[round(center[0] + ca * x - sa * y, 6), round(center[1] + sa * x + ca * y, 6)]
                       for x, y in pts]}

    h, t = size / 2, thickness
    return [box(h - t, -h, h, h), box(-h, h - t, h - t, h), box(-h, -h, h - t, -h + t)]


def jittered(n: int, seed: int, spacing: float = 0.55) -> list[list[float]]:
    """Place the root at the origin and n - 1 robots on the grid points nearest to it (a disc).

    Each robot is moved by up to 0.1 m at random: the run's random initialisation.
    """
    rng = np.random.default_rng([seed, n, 6])
    k = int(math.ceil(math.sqrt(n))) + 1
    grid = sorted(((i * spacing, j * spacing) for i in range(-k, k + 1) for j in range(-k, k + 1) if (i, j) != (0, 0)),
                  key=lambda p: (round(math.hypot(*p), 6), p))
    return [[0.0, 0.0]] + [[round(x + rng.uniform(-0.1, 0.1), 4), round(y + rng.uniform(-0.1, 0.1), 4)]
                           for x, y in grid[: n - 1]]


def condition(targets: int, obstacle: bool, wp: bool, seed: int, ticks: int, ask: str = "stretched",
              route: str = "first") -> dict:
    angles = [2 * math.pi * k / targets for k in range(targets)]
    tg = [[round(RADIUS * math.cos(a), 4), round(RADIUS * math.sin(a), 4)] for a in angles]
    obstacles = [o for a in angles for o in c_shape([5.0 * math.cos(a), 5.0 * math.sin(a)], a)] if obstacle else None
    n = 9 * targets + 4
    extra = {} if route == "first" else {"route": route}  # the default stays out of the scenario
    return relays_scenario(n, tg, ticks=ticks, seed=seed, obstacles=obstacles, wp=wp, ask=ask, **extra,
                           positions=jittered(n, seed),
                           checks=[{"use": "relays.reached", "slack": 100.0}, {"use": "relays.links_within_db"}])


def _run(job: dict) -> dict:
    from swarmactors.runs.launcher import run

    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        r = run(job["scenario"], out=tmp)
        dt = r["scenario"]["run"]["dt"]
        reports = r.reports("relays")
        paths = [rep["path"] for rep in reports.values() if rep.get("path")]
        longest = max((sum(math.dist(a[:2], b[:2]) for a, b in zip(p, p[1:], strict=False)) for p in paths),
                      default=None)
        reached = [c for c in r.checks if c["name"] == "relays.reached"]
        healed = [c for c in r.checks if c["name"] == "relays.healed"]
        verdicts = r.verdicts()  # the sweep counts the failed ones
        out = {**{k: v for k, v in job.items() if k != "scenario"}, "wall_s": round(time.time() - t0, 1),
               "all_reached": verdicts.get("relays.reached", True), "path_m": longest,
               "last_reached_s": max((c["value"] for c in reached if c["value"] is not None), default=None),
               "links_ok": verdicts.get("relays.links_within_db", True),
               "recovery_s": healed[0]["value"] if healed else None,
               "back_s": _back(healed[0]["detail"]) if healed else None,
               "chain": _chain(reports), "dt": dt, **_who(reports, dt), "checks": verdicts}
    at = 1 * dt  # the root writes the targets at tick 1
    if out["all_reached"] and out["last_reached_s"] is not None and longest:
        out["time_factor"] = (out["last_reached_s"] - at) / (longest / 0.5)
    return out


def _who(reports: dict, dt: float) -> dict:
    """Who recruited (the behaviour's own records, R5): every slot opened, every request kept, the heads' stops.

    ``recruits``: [recruiter, opened s, depth, robots above it to the head, stretched, asked s or None,
    closed s, winner, joined s or None]; ``asks``: [robot, s, depth, robots above it, stretched];
    ``head_stopped_s`` / ``head_s``: per worker, the time it stood still on its path before its target / in all.
    """
    def sec(t):
        return None if t is None else round(t * dt, 3)

    rec, asks, stopped, head = [], [], [], []
    for rid, rep in sorted(reports.items()):
        for o, d, up, st, a, c, w, j in rep.get("recruits", []):
            rec.append([rid, sec(o), d, up, st, sec(a), sec(c), w, sec(j)])
        asks += [[rid, sec(t), d, up, st] for t, d, up, st in rep.get("asked", [])]
        if rep.get("head_ticks"):
            stopped.append(sec(rep["head_stopped"]))
            head.append(sec(rep["head_ticks"]))
    return {"recruits": rec, "asks": asks, "head_stopped_s": stopped, "head_s": head}


def _back(detail: str) -> float | None:
    """The worker's time back at its target after the (first) kill, from relays.healed's detail."""
    m = re.search(r"worker back at its target after ([0-9.]+) s", detail or "")
    return float(m.group(1)) if m else None


def _chain(reports: dict) -> list[int]:
    """The worker's chain at the end of the run, up its parents; it stops short of the root where one is cut."""
    workers = [r for r, rep in reports.items() if rep["role"] == "worker"]
    if len(workers) != 1:
        return []
    out = [workers[0]]
    while reports[out[-1]]["role"] != "root" and len(out) < 100 and reports[out[-1]]["parent"] in reports:
        out.append(reports[out[-1]]["parent"])
    return out


def mean_ci(xs: list[float]) -> tuple[float, float]:
    """Mean and half-width of its 95 % confidence interval (Student t)."""
    from scipy import stats

    xs = [x for x in xs if x is not None]
    if len(xs) < 2:
        return (xs[0] if xs else math.nan), math.nan
    return float(np.mean(xs)), float(stats.t.ppf(0.975, len(xs) - 1) * np.std(xs, ddof=1) / math.sqrt(len(xs)))


def diff_ci(a: list[float], b: list[float]) -> tuple[float, float, float]:
    """Mean of a - b, the half-width of its 95 % CI (Welch) and the p-value of Welch's t-test."""
    from scipy import stats

    a, b = [x for x in a if x is not None], [x for x in b if x is not None]
    if len(a) < 2 or len(b) < 2:
        return math.nan, math.nan, math.nan
    va, vb = np.var(a, ddof=1) / len(a), np.var(b, ddof=1) / len(b)
    se = math.sqrt(va + vb)
    dof = (va + vb) ** 2 / (va ** 2 / (len(a) - 1) + vb ** 2 / (len(b) - 1)) if se > 0 else 1
    p = float(stats.ttest_ind(a, b, equal_var=False).pvalue) if se > 0 else math.nan
    return float(np.mean(a) - np.mean(b)), float(stats.t.ppf(0.975, dof) * se), p


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=35, help="runs per condition (the paper: 35)")
    ap.add_argument("--fail-runs", type=int, default=None, help="runs per failure factor (default: --runs)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "results" / "fig6.json"))
    ap.add_argument("--only", choices=["tf", "fail"], default=None)
    ap.add_argument("--plot", default=None, help="plot a results file to docs/img/relays_fig6.png and stop")
    args = ap.parse_args()
    if args.plot:
        plot(json.loads(Path(args.plot).read_text()))
        return
    jobs = []
    if args.only != "fail":
        for targets in (2, 3, 4):
            for obstacle in (False, True):
                for wp in (False, True):
                    for seed in range(args.runs):
                        ticks = 500 if obstacle else 450
                        jobs.append({"kind": "tf", "targets": targets, "obstacle": obstacle, "wp": wp,
                                     "seed": seed, "scenario": condition(targets, obstacle, wp, seed, ticks)})
    results = []
    with mp.get_context("spawn").Pool(args.workers) as pool:
        for i, res in enumerate(pool.imap(_run, jobs)):
            results.append(res)
            print(i + 1, len(jobs), {k: res[k] for k in ("targets", "obstacle", "wp", "seed", "time_factor",
                                                           "wall_s") if k in res}, flush=True)
        if args.only != "tf":
            results += failures(pool, args.fail_runs or args.runs)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(results, indent=1))
    summarise(results)


def failures(pool, runs: int) -> list[dict]:
    """Build one 10 m chain per seed (12 robots + 2 spare), then kill f = 1..5 consecutive networkers."""
    n, built = 14, 330
    base = [{"kind": "base", "seed": s, "scenario": relays_scenario(n, [[RADIUS, 0.0]], ticks=built, seed=s,
                                                                   positions=jittered(n, s), checks=[])}
            for s in range(runs)]
    bases = pool.map(_run, base)
    jobs = []
    for b in bases:
        chain = b["chain"]  # worker, ..., root
        nets = chain[1:-1]
        for f in range(1, 6):
            if len(nets) < f:
                continue
            sc = relays_scenario(n, [[RADIUS, 0.0]], ticks=built + 400, seed=b["seed"],
                                 positions=jittered(n, b["seed"]), kills=[(built, nets[:f])],
                                 checks=failure_checks())
            jobs.append({"kind": "fail", "seed": b["seed"], "failed": f, "networkers": len(nets), "scenario": sc})
    out = []
    for res in pool.imap(_run, jobs):
        print("fail", {k: res[k] for k in ("seed", "failed", "networkers", "recovery_s", "wall_s")}, flush=True)
        out.append(res)
    return out


def variant(r: dict) -> str:
    """A time-factor row's recruiting variant: "WP", or "no WP (stretched)" / "no WP (plan)" by ``ask`` (R5).

    The name adds ", to the base" when ``route`` = "base".
    """
    if r["wp"]:
        return "WP"
    return f"no WP ({r.get('ask') or 'stretched'}{', to the base' if r.get('route') == 'base' else ''})"


def summarise(results: list[dict]) -> None:
    """Print the time factor per cell and variant, each variant against WP (Welch), and the failure slope."""
    tf = [r for r in results if r["kind"] == "tf"]
    names = sorted({variant(r) for r in tf})
    for obstacle in (False, True):
        for targets in (2, 3, 4, None):  # None: pooled over the number of targets
            cells = {v: [r.get("time_factor") for r in tf if variant(r) == v and r["obstacle"] == obstacle
                         and targets in (None, r["targets"])] for v in names}
            if not any(cells.values()) or (targets is None and len({r["targets"] for r in tf}) < 2):
                continue
            where = f"T={targets if targets else 'all'} {'C' if obstacle else 'open'}"
            for v in names:
                m, h = mean_ci(cells[v])
                line = f"{where} {v}: {m:.3f} ± {h:.3f} ({sum(x is not None for x in cells[v])}/{len(cells[v])})"
                if v != "WP" and cells.get("WP"):
                    d, hd, p = diff_ci(cells["WP"], cells[v])
                    line += f"; WP - this = {d:+.3f} ± {hd:.3f} ({100 * d / m:+.1f} %), Welch p = {p:.2g}"
                print(line)
    fl = [r for r in results if r["kind"] == "fail"]
    for f in range(1, 6):
        xs = [r["recovery_s"] for r in fl if r["failed"] == f]
        if xs:
            m, h = mean_ci(xs)
            b, hb = mean_ci([r.get("back_s") for r in fl if r["failed"] == f])
            print(f"failed {f}: recovery {m:.2f} ± {h:.2f} s over {len([x for x in xs if x is not None])} runs; "
                  f"worker back at its target {b:.1f} ± {hb:.1f} s")
    for key in ("recovery_s", "back_s"):
        fit = slope(fl, key)
        if fit:
            print(f"{key}: {fit['slope']:+.2f} ± {fit['half']:.2f} s per failed robot (95 % CI, {fit['n']} runs); "
                  f"per traversal time ({fit['traversal']:.0f} s): {100 * fit['slope'] / fit['traversal']:+.1f} ± "
                  f"{100 * fit['half'] / fit['traversal']:.1f} % of the time factor")


def slope(rows: list[dict], key: str = "recovery_s") -> dict | None:
    """Least-squares line of ``key`` against the number of failed robots; slope, its 95 % CI (Student t).

    ``traversal`` is the chain's traversal time, path length / v_max, the time factor's denominator.
    """
    from scipy import stats

    pts = [(r["failed"], r[key]) for r in rows if r.get(key) is not None]
    if len({f for f, _ in pts}) < 2 or len(pts) < 3:
        return None
    fit = stats.linregress(*zip(*pts, strict=True))
    paths = [r["path_m"] for r in rows if r.get("path_m")]
    return {"slope": fit.slope, "half": stats.t.ppf(0.975, len(pts) - 2) * fit.stderr, "n": len(pts),
            "intercept": fit.intercept, "traversal": (float(np.mean(paths)) if paths else RADIUS) / 0.5}


def sweep_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One time-factor run of ``fig6.toml``: condition (targets, obstacle, wp, ask, route), jitter ``trial``.

    ``ask`` (default "stretched") is when a head without WP asks for a robot, ``route`` (default "first") where its
    request stops (R5); neither acts with WP.
    """
    targets, obstacle, wp = int(params["targets"]), bool(params["obstacle"]), bool(params["wp"])
    ask, route = str(params.get("ask", "stretched")), str(params.get("route", "first"))
    ticks = 500 if obstacle else 450
    return _run({"kind": "tf", "targets": targets, "obstacle": obstacle, "wp": wp, "ask": ask, "route": route,
                 "seed": trial, "scenario": condition(targets, obstacle, wp, trial, ticks, ask, route)})


def sweep_failure_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One run of ``fig6-failures.toml``: build chain ``trial`` (as ``failures``), kill f networkers.

    The chain is built by its own run first (the same run for every f), so a trial is self-contained.
    """
    n, built, f = 14, 330, int(params["failed"])
    link_fail = float(params.get("link_fail", 5.0))  # the paper's link failure declaration time (Sec. V)
    base = _run({"kind": "base", "seed": trial, "scenario": relays_scenario(
        n, [[RADIUS, 0.0]], ticks=built, seed=trial, positions=jittered(n, trial), checks=[], link_fail=link_fail)})
    nets = base["chain"][1:-1]
    if len(nets) < f:
        return {"kind": "fail", "seed": trial, "failed": f, "networkers": len(nets), "recovery_s": None,
                "skipped": "chain too short"}
    sc = relays_scenario(n, [[RADIUS, 0.0]], ticks=built + 400, seed=trial, positions=jittered(n, trial),
                         kills=[(built, nets[:f])], link_fail=link_fail,
                         checks=failure_checks())
    return _run({"kind": "fail", "seed": trial, "failed": f, "networkers": len(nets), "link_fail": link_fail,
                 "scenario": sc})


def sweep_figures(csv_path: Path, out_dir: Path) -> list[Path]:
    """The sweeps' post step: Fig. 6's panels (those the sweep measured) and the printed summary."""
    from swarmactors.tools.sweep import returned_values

    results = returned_values(csv_path)
    summarise(results)
    path = Path(out_dir) / "relays_fig6.png"
    plot(results, path)
    return [path]


def plot(results: list[dict], path: Path = Path("docs/img/relays_fig6.png")) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    tf = [r for r in results if r["kind"] == "tf"]
    ax = axes[0]
    lines = [(obstacle, v) for obstacle in (False, True) for v in sorted({variant(r) for r in tf})]
    for k, (obstacle, v) in enumerate(lines):
        xs, ms, hs = [], [], []
        for targets in sorted({r["targets"] for r in tf}):
            m, h = mean_ci([r.get("time_factor") for r in tf if (r["targets"], r["obstacle"], variant(r))
                            == (targets, obstacle, v)])
            xs.append(targets + (k - (len(lines) - 1) / 2) * 0.06)
            ms.append(m)
            hs.append(h)
        ax.errorbar(xs, ms, yerr=hs, marker="o", capsize=3, label=f"{'C obstacle' if obstacle else 'open'}, {v}")
    ax.set_xlabel("targets")
    ax.set_ylabel("time factor (build time / traversal time)")
    ax.set_xticks([2, 3, 4])
    ax.legend(fontsize=8)
    ax.set_title("Fig. 6 middle/top (ours, mean ± 95 % CI)")
    ax = axes[1]
    fl = [r for r in results if r["kind"] == "fail"]
    fs = sorted({r["failed"] for r in fl})
    ms, hs = zip(*[mean_ci([r["recovery_s"] for r in fl if r["failed"] == f]) for f in fs], strict=False) \
        if fs else ([], [])
    ax.errorbar(fs, ms, yerr=hs, marker="o", capsize=3)
    nets = [r["networkers"] for r in fl if r.get("networkers") is not None]
    span = f" (chains of {min(nets)}-{max(nets)} networkers at the kill)" if nets else ""
    ax.set_xlabel(f"consecutive networkers failed{span}")
    ax.set_ylabel("recovery time (s), 5 s link-failure time included")
    ax.set_title("Fig. 6 bottom (ours)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()

#!/usr/bin/env python
"""Kobayashi et al.'s role switching: the paper's experiments (Sec. IV), our numbers beside the paper's.

    python -m protocols.roles.experiments.paper [--trials T] [--only prelim|main] [--jobs J] [--quick]
        [--img docs/img] [--out protocols/roles/experiments/results/paper.json]

Preliminary (Sec. IV-A, Figs. 3-5): N explorers on a random walk (step 1 per timestep, uniform direction),
d_c = d_s = 3, eta_c = 3, field sqrt(N) x sqrt(N), 1000 timesteps, N = 10, 20, ..., 100; Algorithm 2
(``proposed``) and the every-tick baseline, on the same walk (same seed: the walk draws only from the robots'
own generators). Per robot and trial: angle tests (the machine-independent cost), wall time of the
connection-management code, and the mean algebraic connectivity of the formed network (sampled every 10
ticks).

Main (Sec. IV-B, Figs. 6-11): the patrol, N = 10, 20, ..., 50, 2000 timesteps; disconnections from the base
station and their lengths (oracle), processing time per robot and per role, received messages per robot per
timestep, targets reached. ``--only witnesses``: the patrol with the paper's witness set as printed
(``witnesses = "all"``), resuming (trials already in the JSON file are kept), and Fig. 7 redrawn with both
witness sets (``docs/img/roles-fig7-witnesses.png``, also by ``--replot``).

Trials run over worker processes (``spawn``), each in lockstep with its own seed. Plots go to
``docs/img/roles-*.png``; every number to the JSON file. With ``--quick``: fewer sizes and ticks, for a smoke
run.

Both experiments as sweeps (a trial = one run of ``prelim_job`` / ``main_job``; the post step draws the
figures and writes the aggregates beside trials.csv), locally or on a Dask cluster, with the paper's 30 trials:

    swarmactors sweep protocols/roles/experiments/fig3-5.toml [--cluster tcp://SCHEDULER:8786] [--trials 3]
    swarmactors sweep protocols/roles/experiments/fig6-11.toml [--cluster ...] [--set witnesses='"all"'] [--set d_s=2.0]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import multiprocessing
import platform
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]  # the checkout: docs/img

PAPER = {
    "aat_cost_reduction": "35-80 % less than the baseline, more at larger N (Fig. 4; wall time of the paper's "
                          "simulator)",
    "lambda2_reduction": "5-20 % lower than the baseline, more at larger N (Fig. 5)",
    "disconnections": "a few dozens per trial at most, more for smaller N (Fig. 7a)",
    "recovery": "every disconnection recovered within a few to dozens of timesteps (Fig. 7b)",
    "disconnected_total_n10": "about 100 timesteps per trial (mean at N = 10), 5 % of the mission",
    "processing_time": "at most 8 s per 2000-timestep mission, <= 0.01 s per timestep (Figs. 8-10)",
    "processing_growth": "about +50 % from N = 10 to N = 50 (Fig. 10)",
    "messages": "received messages per robot per timestep grow more slowly than N (Fig. 11)",
    "roles": "local leader and explorers cost more than base station and repeaters (Fig. 9)",
}


# ================================================================== one run
def _run(raw: dict, keep: Path | None = None):
    from swarmactors.runs.launcher import new_run_id, run_world
    from swarmactors.runs.scenario import resolve_scenario
    from transport import Endpoints

    sc = resolve_scenario(raw, "<experiment>")
    out = keep if keep is not None else Path(tempfile.mkdtemp(prefix="roles-exp-"))
    return asyncio.run(run_world(sc, out, Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                                 new_run_id(sc["run"]["name"])))


def prelim_job(n: int, seed: int, ticks: int) -> dict:
    """One trial of Sec. IV-A: both modes on the same walk."""
    import shutil

    from protocols.roles.oracle import connectivity
    from protocols.roles.scenarios import aat_scenario

    logging.getLogger().setLevel(logging.ERROR)
    row = {"n": n, "seed": seed, "ticks": ticks}
    for mode in ("proposed", "baseline"):
        result = _run(aat_scenario(n, seed, ticks, mode=mode))
        reps = result.reports("aat")
        lam = connectivity(result, every=10).value
        row[mode] = {
            "tests_per_robot": float(np.mean([r["aat"]["tests"] for r in reps.values()])),
            "wall_s_per_robot": float(np.mean([r["aat"]["wall_s"] for r in reps.values()])),
            "runs_per_robot": float(np.mean([r["aat"]["runs"] for r in reps.values()])),
            "lambda2": lam,
            "degree": float(np.mean([len(r["connections"]) for r in reps.values()])),
            "wall_s": result["wall_s"],
        }
        shutil.rmtree(result.path.parent, ignore_errors=True)
    return row


def triggers_job(n: int, seed: int, ticks: int) -> dict:
    """Sec. IV-A, one walk: Algorithm 2's cost by trigger, with and without the circle tests of lines 9-15.

    Three runs on the same walk (the walk draws only from ``ctx.rng``): proposed, proposed without lines 9-15
    (``circles = false``: links are kept unless the role changed or |A_i| < eta_c) and the baseline, whose
    links are the Gabriel graph cut at d_c (its mean degree is the Gabriel degree of the configuration).
    """
    import shutil

    from protocols.roles.oracle import connectivity
    from protocols.roles.scenarios import aat_scenario

    logging.getLogger().setLevel(logging.ERROR)
    row = {"n": n, "seed": seed, "ticks": ticks}
    for label, kw in (("proposed", {}), ("no_circles", {"circles": False}), ("baseline", {"mode": "baseline"})):
        result = _run(aat_scenario(n, seed, ticks, **kw))
        reps = [r["aat"] for r in result.reports("aat").values()]
        calls = sum(r["calls"] for r in reps)
        trig = {k: float(np.mean([r["tests_by_trigger"][k] for r in reps])) for k in reps[0]["tests_by_trigger"]}
        runs = {k: float(np.mean([r["runs_by_trigger"][k] for r in reps])) for k in reps[0]["runs_by_trigger"]}
        full = sum(r["runs_by_trigger"]["role"] + r["runs_by_trigger"]["degree"] for r in reps)
        row[label] = {
            "tests_per_robot": float(np.mean([r["tests"] for r in reps])),
            "baseline_tests_per_robot": float(np.mean([r["baseline_tests"] for r in reps])),
            "tests_by_trigger": trig, "runs_by_trigger": runs,
            "below_eta_fraction": sum(r["below_eta"] for r in reps) / max(calls, 1),
            "mean_degree_before": sum(r["degree_sum"] for r in reps) / max(calls, 1),
            "gabriel_degree_on_full_tests": sum(r["full_passed"] for r in reps) / max(full, 1),
            "lambda2": connectivity(result, every=10).value,
            "degree_end": float(np.mean([len(r["connections"]) for r in result.reports("aat").values()])),
        }
        shutil.rmtree(result.path.parent, ignore_errors=True)
    return row


def main_job(n: int, seed: int, ticks: int, params: dict | None = None) -> dict:
    """One patrol trial of Sec. IV-B; ``params`` go to ``patrol_scenario`` (``d_s``: the groups' sensing range)."""
    import shutil

    from protocols.roles.oracle import disconnection_episodes
    from protocols.roles.scenarios import patrol_scenario

    logging.getLogger().setLevel(logging.ERROR)
    result = _run(patrol_scenario(n, seed, ticks, checks=[{"use": "roles.leader"}, {"use": "roles.chain"},
                                                          {"use": "roles.gabriel"}], **(params or {})))
    reps = result.reports("roles")
    m = result["metrics"]["roles"]
    info = disconnection_episodes(result)
    last = info["last"]
    lengths = [(e[2] if e[2] is not None else last + 1) - e[1] for e in info["episodes"]]
    per_role: dict[str, list[float]] = {}
    for r in reps.values():
        for role, cpu in r["cpu_by_role"].items():
            t = r["ticks_by_role"].get(role, 0)
            if t:
                per_role.setdefault(role, []).append(cpu / t * ticks)  # seconds per mission-length in that role
    row = {
        "n": n, "seed": seed, "ticks": ticks,
        "targets": m["targets_reached"],
        "handovers": m["handovers_done"], "extend": m["handovers_extend"], "retract": m["handovers_retract"],
        "disconnections": len(lengths),
        "disconnection_mean": float(np.mean(lengths)) if lengths else 0.0,
        "disconnection_max": max(lengths, default=0),
        "disconnected_robot_ticks": int(sum(lengths)),
        "disconnected_ticks": sum(1 for _, k in info["per_tick"] if k),
        "open_at_end": sum(e[2] is None for e in info["episodes"]),
        "cpu_s": {int(rid): r["cpu_s"] for rid, r in reps.items()},
        "cpu_s_per_robot": float(np.mean([r["cpu_s"] for r in reps.values()])),
        "cpu_s_by_role": per_role,
        "received_per_tick": float(np.mean([r["received_per_tick"] for r in reps.values()])),
        "received_per_tick_by_kind": {k: float(np.mean([r["received_by_kind"].get(k, 0) / r["ticks"]
                                                        for r in reps.values()]))
                                      for k in sorted({k for r in reps.values() for k in r["received_by_kind"]})},
        # what the radio carried to each robot: deliveries plus the overheard copies it discarded
        "radio_per_tick": float(np.mean([(result.frame_counts(rid)["received"]
                                          + result.frame_counts(rid).get("overheard", 0)) / ticks for rid in reps])),
        "overheard_per_tick": float(np.mean([result.frame_counts(rid).get("overheard", 0) / ticks for rid in reps])),
        "aat_saving": m["aat_saving"],
        "repeaters_max": max(sum(1 for r in reps.values() if r["role"] == "repeater"), 0),
        "checks": result.verdicts(),
        "wall_s": result["wall_s"],
    }
    shutil.rmtree(result.path.parent, ignore_errors=True)
    return row


def run_jobs(fn, args: list[tuple], jobs: int, label: str) -> list[dict]:
    out = []
    t0 = time.time()
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        futs = {pool.submit(fn, *a): a for a in args}
        for k, fut in enumerate(as_completed(futs), 1):
            out.append(fut.result())
            print(f"  {label}: {k}/{len(args)} done ({time.time() - t0:.0f} s)", flush=True)
    return out


def prelim_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One trial of ``fig3-5.toml`` (beside this module): N = ``n``, walk seed 1000 + ``trial`` (as ``main``)."""
    return prelim_job(int(params["n"]), 1000 + trial, int(params["ticks"]))


def main_trial(params: dict, *, seed: int, trial: int) -> dict:
    """One patrol of ``fig6-11.toml``: N = ``n``, seed 2000 + ``trial``; d_s, witnesses passed on."""
    extra = {k: v for k, v in params.items() if k in ("d_s", "witnesses")}
    return main_job(int(params["n"]), 2000 + trial, int(params["ticks"]), extra)


def prelim_figures(csv_path: Path, out_dir: Path) -> list[Path]:
    """The post step of the Figs. 3-5 sweep: the plots and ``preliminary.json`` (aggregates by N)."""
    from swarmactors.tools.sweep import returned_values

    out = Path(out_dir)
    agg = plot_prelim(returned_values(csv_path), out, None)
    (out / "preliminary.json").write_text(json.dumps({"by_n": agg, "paper": PAPER}, indent=1, default=float))
    return [out / "preliminary.json", *sorted(out.glob("roles-*.png"))]


def main_figures(csv_path: Path, out_dir: Path) -> list[Path]:
    """The post step of the Figs. 6-11 sweep: the plots and ``main.json`` (aggregates by N)."""
    out = Path(out_dir)
    agg = plot_main(main_rows(csv_path), out)
    (out / "main.json").write_text(json.dumps({"by_n": agg, "paper": PAPER}, indent=1, default=float))
    return [out / "main.json", *sorted(out.glob("roles-*.png"))]


def main_rows(csv_path: Path) -> list[dict]:
    """The Figs. 6-11 sweep's trials.csv read back as the rows ``main_job`` returned.

    The CSV has one column per key any trial returned, so a cell is empty where that trial's dict had no such
    key: ``metric.cpu_s.<id>`` of a robot that does not exist at that N, ``received_per_tick_by_kind.<kind>``
    of a kind no robot received in that run. Those keys are dropped, not read as 0: a missing robot is not a
    robot with no processing time (it would pull Fig. 10's boxes and the per-robot mean down), and a kind that
    was never received counts as 0 per tick only where the aggregate asks for it (``plot_main``: ``.get(k, 0)``),
    as it did for the rows of ``main_job``.
    """
    from swarmactors.tools.sweep import returned_values

    rows = returned_values(csv_path)
    for r in rows:
        # JSON keys are strings; the plots index robots by int
        r["cpu_s"] = {int(k): v for k, v in r["cpu_s"].items() if v is not None}
        r["received_per_tick_by_kind"] = {k: v for k, v in (r.get("received_per_tick_by_kind") or {}).items()
                                          if v is not None}
        r["checks"] = dict(_dotted(r.get("checks") or {}))  # "roles.chain" came back as {"roles": {"chain": ..}}
    return rows


def _dotted(d: dict, prefix: str = ""):
    """A nested dict's leaves as (dotted key, value), empty cells (None) left out."""
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _dotted(v, f"{prefix}{k}.")
        elif v is not None:
            yield f"{prefix}{k}", v


def _saved(results: Path, key: str) -> list[dict]:
    rows = json.loads(Path(results).read_text())[key]["rows"]
    for r in rows:  # JSON keys are strings; the plots index robots by int
        if "cpu_s" in r:
            r["cpu_s"] = {int(k): v for k, v in r["cpu_s"].items()}
    return rows


def replot_prelim(results: Path, out_dir: Path) -> list[Path]:
    """Figs. 4-5 re-drawn from the saved results (Fig. 3, a snapshot of one run, only by ``--replot``).

    From the 30-trial sweep's rows (``fig3-5_sweep.csv`` beside ``paper.json``) when they are there, else from
    ``paper.json``'s preliminary rows.
    """
    from swarmactors.tools.sweep import returned_values

    sweep = Path(results).parent / "fig3-5_sweep.csv"
    plot_prelim(returned_values(sweep) if sweep.exists() else _saved(results, "preliminary"), Path(out_dir), None)
    return [Path(out_dir) / "roles-fig4-aat-cost.png", Path(out_dir) / "roles-fig5-lambda2.png"]


def replot_main(results: Path, out_dir: Path) -> list[Path]:
    """Figs. 7-11 and Fig. 7 under both witness sets, re-drawn from the saved results.

    Figs. 7-11 from the 30-trial sweep's rows (``fig6-11_sweep.csv`` beside ``paper.json``) when they are
    there, else from ``paper.json``'s main rows; Fig. 7 under both witness sets from ``paper.json`` (its
    "ours" side: its 10 main trials per N). Fig. 6 (snapshots of one run) is drawn only by ``--replot``,
    which runs it again.
    """
    out = Path(out_dir)
    saved = _saved(results, "main")
    sweep = Path(results).parent / "fig6-11_sweep.csv"
    plot_main(main_rows(sweep) if sweep.exists() else saved, out)
    paths = [out / f"roles-{n}.png" for n in ("fig7-disconnections", "fig8-per-robot", "fig9-per-role",
                                              "fig10-11-cost-messages")]
    if "witnesses_all" in json.loads(Path(results).read_text()):
        paths.append(plot_fig7_witnesses(saved, _saved(results, "witnesses_all"), out))
    return paths


# ================================================================== plots
def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_prelim(rows: list[dict], img: Path, fig3: dict | None) -> dict:
    plt = _plt()
    ns = sorted({r["n"] for r in rows})
    agg = {}
    for n in ns:
        rs = [r for r in rows if r["n"] == n]
        a = {}
        for mode in ("proposed", "baseline"):
            for k in ("tests_per_robot", "wall_s_per_robot", "lambda2", "degree", "runs_per_robot"):
                a[f"{mode}_{k}"] = float(np.mean([r[mode][k] for r in rs]))
        a["tests_reduction"] = 1 - a["proposed_tests_per_robot"] / a["baseline_tests_per_robot"]
        a["wall_reduction"] = 1 - a["proposed_wall_s_per_robot"] / a["baseline_wall_s_per_robot"]
        a["lambda2_reduction"] = 1 - a["proposed_lambda2"] / a["baseline_lambda2"] if a["baseline_lambda2"] else None
        a["trials"] = len(rs)
        agg[n] = a
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2), dpi=110)
    for mode, c in (("proposed", "tab:blue"), ("baseline", "tab:orange")):
        ax[0].plot(ns, [agg[n][f"{mode}_tests_per_robot"] / 1e3 for n in ns], "o-", color=c, label=mode)
        ax[1].plot(ns, [agg[n][f"{mode}_wall_s_per_robot"] * 1e3 for n in ns], "o-", color=c, label=mode)
    ax[0].set_ylabel("angle tests per robot per trial (thousands)")
    ax[1].set_ylabel("connection-management wall time per robot per trial (ms)")
    for a in ax:
        a.set_xlabel("N")
        a.legend()
        a.grid(alpha=0.3)
    red = ", ".join(f"N={n}: {100 * agg[n]['tests_reduction']:.0f}%" for n in ns[:: max(1, len(ns) // 4)])
    fig.suptitle(f"Fig. 4 (ours): cost of Algorithm 2 vs the every-tick baseline; fewer tests: {red}", fontsize=9)
    fig.tight_layout()
    fig.savefig(img / "roles-fig4-aat-cost.png")
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 4.2), dpi=110)
    for mode, c in (("proposed", "tab:blue"), ("baseline", "tab:orange")):
        ax.plot(ns, [agg[n][f"{mode}_lambda2"] for n in ns], "o-", color=c, label=mode)
    ax.set_xlabel("N")
    ax.set_ylabel("mean algebraic connectivity of the formed network")
    ax.set_title("Fig. 5 (ours): algebraic connectivity", fontsize=10)
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(img / "roles-fig5-lambda2.png")
    plt.close(fig)

    if fig3:
        fig, ax = plt.subplots(1, 2, figsize=(11, 5.2), dpi=110)
        for a, mode in zip(ax, ("proposed", "baseline"), strict=True):
            pos = {int(k): v for k, v in fig3["pos"].items()}
            for i, j in fig3[mode]:
                a.plot(*zip(pos[i], pos[j], strict=True), color="0.4", lw=1)
            for i, j in fig3["missing"] if mode == "proposed" else []:
                a.plot(*zip(pos[i], pos[j], strict=True), color="red", lw=1, ls="--")
            xy = np.array(list(pos.values()))
            a.scatter(xy[:, 0], xy[:, 1], s=60, c="white", edgecolors="tab:blue", zorder=3)
            for rid, p in pos.items():
                a.annotate(str(rid), p, fontsize=6, ha="center", va="center", zorder=4)
            a.set_aspect("equal")
            a.set_title(f"{mode}: {len(fig3[mode])} links" + (
                f" ({len(fig3['missing'])} Gabriel edges missing, dashed)" if mode == "proposed" else ""), fontsize=9)
        fig.suptitle(f"Fig. 3 (ours): N = {fig3['n']}, same positions at tick {fig3['tick']} (the walk stopped at "
                     f"tick {fig3['walk_until']})", fontsize=10)
        fig.tight_layout()
        fig.savefig(img / "roles-fig3-topology.png")
        plt.close(fig)
    return agg


def fig3_snapshot(n: int = 20, seed: int = 3, ticks: int = 200, walk_until: int | None = 150) -> dict:
    """Run both modes on the same walk (stopped at ``walk_until``) and return the links at the last tick."""
    from protocols.roles.oracle import timeline
    from protocols.roles.scenarios import aat_scenario

    out = {"n": n, "seed": seed, "walk_until": walk_until}
    for mode in ("proposed", "baseline"):
        with tempfile.TemporaryDirectory() as d:
            result = _run(aat_scenario(n, seed, ticks, mode=mode, walk_until=walk_until), Path(d))
            *_, (t, pos, st) = list((t, dict(p), {k: dict(v) for k, v in s.items()}) for t, p, s in timeline(result))
            links = sorted({(min(i, j), max(i, j)) for i in pos for j in st[i].get("conn", [])
                            if i in st[j].get("conn", [])})
            out[mode] = links
            out["pos"] = {int(k): [float(v[0]), float(v[1])] for k, v in pos.items()}
            out["tick"] = t
    out["missing"] = sorted(set(map(tuple, out["baseline"])) - set(map(tuple, out["proposed"])))
    return out


def fig6_snapshots(img: Path, n: int = 10, seed: int = 1, ticks: int = 2000) -> dict:
    """Plot a typical patrol (Fig. 6): the swarm at four moments."""
    from protocols.roles.oracle import formed_graph, timeline
    from protocols.roles.scenarios import patrol_scenario

    plt = _plt()
    with tempfile.TemporaryDirectory() as d:
        result = _run(patrol_scenario(n, seed, ticks), Path(d))
        reps = result.reports("roles")
        bs = reps[0]
        changes = sorted((t, rid, role) for rid, r in reps.items() for t, role in r["roles"][1:])
        first_rep = next((t for t, _, role in changes if role == "repeater"), 0)
        # the tick with the longest chain, then the first retraction after it
        role_now = {rid: r["roles"][0][1] for rid, r in reps.items()}
        longest, t_long = -1, first_rep
        for t, rid, role in changes:
            role_now[rid] = role
            k = sum(v == "repeater" for v in role_now.values())
            if k > longest:
                longest, t_long = k, t
        retract = next((t for t, _, role in changes if role == "explorer" and t > t_long), t_long + 100)
        moments = sorted({0, min(first_rep + 30, ticks - 1), min(t_long + 20, ticks - 1),
                          min(retract + 30, ticks - 1)})
        snaps = {}
        for t, pos, st in timeline(result):
            if t in moments:
                g = formed_graph(pos, st, result.ranges()[0])
                snaps[t] = {"pos": {r: p.tolist() for r, p in pos.items()}, "role": {r: st[r]["role"] for r in pos},
                            "links": list(g.edges), "target": st[0].get("target", 0)}
    allp = np.array([p for s in snaps.values() for p in s["pos"].values()] + [bs["targets"][s["target"]]
                                                                               for s in snaps.values()
                                                                               if s["target"] < len(bs["targets"])])
    lo, hi = allp.min(axis=0) - 0.3, allp.max(axis=0) + 0.3
    fig, axes = plt.subplots(1, len(moments), figsize=(17, 4.8), dpi=100)
    style = {"base_station": ("s", "black", "BS"), "repeater": ("^", "black", "RP"),
             "local_leader": ("s", "red", "LL"), "explorer": ("o", "white", "EX")}
    for ax, t in zip(axes, moments, strict=True):
        s = snaps[t]
        for a, b in s["links"]:
            ax.plot(*zip(s["pos"][a], s["pos"][b], strict=True), color="0.5", lw=0.8, zorder=1)
        for role, (mk, fc, lab) in style.items():
            pts = [s["pos"][r] for r in s["pos"] if s["role"][r] == role]
            if pts:
                pts = np.array(pts)
                ax.scatter(pts[:, 0], pts[:, 1], marker=mk, c=fc, edgecolors="tab:blue" if role == "explorer" else fc,
                           s=55, zorder=3, label=lab)
        for r, p in s["pos"].items():
            ax.annotate(str(r), (p[0] + 0.05, p[1] + 0.05), fontsize=6, zorder=4)
        k = s["target"]
        if k < len(bs["targets"]):
            ax.scatter(*bs["targets"][k], marker="*", s=160, c="gold", edgecolors="k", zorder=2, label="target")
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        ax.set_title(f"tick {t}", fontsize=9)
        ax.grid(alpha=0.2)
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle(f"Fig. 6 (ours): a patrol, N = {n}, seed {seed}: start, first repeater, longest chain, "
                 f"after the next retraction", fontsize=10)
    fig.tight_layout()
    fig.savefig(img / "roles-fig6-patrol.png")
    plt.close(fig)
    return {"moments": moments, "targets_reached": len(bs["reached"]), "longest_chain": longest}


def plot_main(rows: list[dict], img: Path, prefix: str = "roles") -> dict:
    plt = _plt()
    ns = sorted({r["n"] for r in rows})
    by = {n: [r for r in rows if r["n"] == n] for n in ns}
    agg = {}
    for n, rs in by.items():
        agg[n] = {
            "trials": len(rs),
            "targets": float(np.mean([r["targets"] for r in rs])),
            "handovers": float(np.mean([r["handovers"] for r in rs])),
            "disconnections": float(np.mean([r["disconnections"] for r in rs])),
            "disconnections_max": max(r["disconnections"] for r in rs),
            "disconnection_mean": float(np.mean([r["disconnection_mean"] for r in rs])),
            "disconnection_max": max(r["disconnection_max"] for r in rs),
            "disconnected_ticks": float(np.mean([r["disconnected_ticks"] for r in rs])),
            "cpu_s_per_robot": float(np.mean([r["cpu_s_per_robot"] for r in rs])),
            "cpu_s_per_robot_max": max(max(r["cpu_s"].values()) for r in rs),
            "cpu_s_by_role": {role: float(np.mean([v for r in rs for v in r["cpu_s_by_role"].get(role, [])]))
                              for role in ("base_station", "repeater", "local_leader", "explorer")
                              if any(r["cpu_s_by_role"].get(role) for r in rs)},
            "received_per_tick": float(np.mean([r["received_per_tick"] for r in rs])),
            "received_per_tick_by_kind": {k: float(np.mean([r["received_per_tick_by_kind"].get(k, 0) for r in rs]))
                                          for k in sorted({k for r in rs for k in r["received_per_tick_by_kind"]})},
            "radio_per_tick": (float(np.mean([r["radio_per_tick"] for r in rs]))
                               if all("radio_per_tick" in r for r in rs) else None),
            "overheard_per_tick": (float(np.mean([r["overheard_per_tick"] for r in rs]))
                                   if all("overheard_per_tick" in r for r in rs) else None),
            "checks_failed": sorted({k for r in rs for k, v in r["checks"].items() if not v}),
        }
    # Fig. 7
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2), dpi=110)
    ax[0].boxplot([[r["disconnections"] for r in by[n]] for n in ns], tick_labels=ns)
    ax[0].set_ylabel("disconnections per trial (robot episodes)")
    ax[1].boxplot([[r["disconnection_mean"] for r in by[n]] for n in ns], tick_labels=ns)
    ax[1].set_ylabel("mean disconnection length per trial (ticks)")
    for a in ax:
        a.set_xlabel("N")
        a.grid(alpha=0.3)
    fig.suptitle("Fig. 7 (ours): disconnections from the base station (oracle) and their lengths", fontsize=10)
    fig.tight_layout()
    fig.savefig(img / f"{prefix}-fig7-disconnections.png")
    plt.close(fig)
    # Fig. 8: per robot at N = 10
    if 10 in by:
        ids = sorted(by[10][0]["cpu_s"])
        fig, ax = plt.subplots(figsize=(7, 4), dpi=110)
        ax.boxplot([[r["cpu_s"][i] for r in by[10]] for i in ids], tick_labels=ids)
        ax.set_xlabel("robot (0 = base station)")
        ax.set_ylabel("processing time per 2000-tick mission (s)")
        ax.set_title("Fig. 8 (ours): processing time per robot, N = 10", fontsize=10)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(img / f"{prefix}-fig8-per-robot.png")
        plt.close(fig)
    # Fig. 9: per role
    roles = ("base_station", "repeater", "local_leader", "explorer")
    fig, axes = plt.subplots(1, 4, figsize=(15, 4), dpi=100, sharey=True)
    for ax, role in zip(axes, roles, strict=True):
        data = [[v for r in by[n] for v in r["cpu_s_by_role"].get(role, [])] or [np.nan] for n in ns]
        ax.boxplot(data, tick_labels=ns)
        ax.set_title(role, fontsize=9)
        ax.set_xlabel("N")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("s per robot, scaled to 2000 ticks")
    fig.suptitle("Fig. 9 (ours): processing time per robot in each role", fontsize=10)
    fig.tight_layout()
    fig.savefig(img / f"{prefix}-fig9-per-role.png")
    plt.close(fig)
    # Fig. 10 and 11
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2), dpi=110)
    ax[0].boxplot([[v for r in by[n] for v in r["cpu_s"].values()] for n in ns], tick_labels=ns)
    ax[0].set_ylabel("processing time per robot per mission (s)")
    ax[0].set_title("Fig. 10 (ours)", fontsize=10)
    ax[1].plot(ns, [agg[n]["received_per_tick"] for n in ns], "o-", label="all kinds (handed over)")
    if all(agg[n].get("radio_per_tick") is not None for n in ns):
        ax[1].plot(ns, [agg[n]["radio_per_tick"] for n in ns], "s-", label="all the radio carried (+ overheard)")
    kinds = sorted({k for n in ns for k in agg[n]["received_per_tick_by_kind"]})
    for k in kinds:
        vals = [agg[n]["received_per_tick_by_kind"].get(k, 0) for n in ns]
        if max(vals) > 0.05:
            ax[1].plot(ns, vals, ".--", lw=0.8, label=k)
    n0 = ns[0]
    ax[1].plot(ns, [agg[n0]["received_per_tick"] * n / n0 for n in ns], ":", color="0.5", label="proportional to N")
    ax[1].set_ylabel("received messages per robot per tick")
    ax[1].set_title("Fig. 11 (ours)", fontsize=10)
    ax[1].legend(fontsize=7)
    for a in ax:
        a.set_xlabel("N")
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(img / f"{prefix}-fig10-11-cost-messages.png")
    plt.close(fig)
    return agg


# ================================================================== main
def plot_fig7_witnesses(ours: list[dict], paper_set: list[dict], img: Path) -> Path:
    """Fig. 7 redrawn with both witness sets of Algorithm 2: ours ("linkable") and the paper's as printed ("all").

    (a) disconnections per trial, (b) their mean length per trial (ticks to recovery), (c) ticks per trial with
    some robot disconnected; one box per N and witness set, every trial a dot. The paper's figure is not in the
    text we have: its statements are quoted on each panel, and its one number (about 100 timesteps per trial at
    N = 10) is marked.
    """
    plt = _plt()
    ns = sorted({r["n"] for r in ours} | {r["n"] for r in paper_set})
    sets = (("ours: local leaders and explorers witness", ours, "tab:blue", -0.18),
            ('paper\'s as printed (witnesses = "all")', paper_set, "tab:orange", 0.18))
    panels = (("disconnections", "disconnections per trial (robot episodes)",
               "paper (Fig. 7a): \"a few dozens at most\",\nmore for smaller swarms"),
              ("disconnection_mean", "mean disconnection length per trial (ticks)",
               "paper (Fig. 7b): every one recovered\n\"within a few to dozens of timesteps\""),
              ("disconnected_ticks", "ticks per trial with a robot disconnected",
               "paper: about 100 timesteps per trial\nat N = 10 (5 % of the mission)"))
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), dpi=110)
    for ax, (field, label, quote) in zip(axes, panels, strict=True):
        for name, rows, colour, dx in sets:
            data = [[r[field] for r in rows if r["n"] == n] for n in ns]
            pos = [i + dx for i, d in enumerate(data) if d]
            bp = ax.boxplot([d for d in data if d], positions=pos, widths=0.3, patch_artist=True,
                            showfliers=False)
            for box in bp["boxes"]:
                box.set(facecolor=colour, alpha=0.35)
            for x, d in zip(pos, [d for d in data if d], strict=True):
                ax.plot([x] * len(d), d, ".", color=colour, alpha=0.8)
            ax.plot([], [], "s", color=colour, alpha=0.5,
                    label=f"{name} ({'/'.join(str(len(d)) for d in data if d)} trials)")
        if field == "disconnected_ticks":
            ax.plot([ns.index(10)], [100], "*", color="black", markersize=12, label="paper, N = 10")
        ax.set_xticks(range(len(ns)), [str(n) for n in ns])
        ax.set_xlabel("N")
        ax.set_ylabel(label)
        ax.set_title(quote, fontsize=8)
        ax.grid(alpha=0.3)
    handles, labels = axes[2].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle("Fig. 7 with both witness sets (d_s = d_c, 2000 ticks; disconnections from the base station "
                 "by the oracle, per robot)", fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    path = img / "roles-fig7-witnesses.png"
    fig.savefig(path)
    plt.close(fig)
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=3, help="trials per N (the paper: 30)")
    ap.add_argument("--only", choices=("prelim", "main", "triggers", "witnesses"), default=None)
    ap.add_argument("--sizes", default=None, help="comma-separated N for --only triggers / witnesses")
    ap.add_argument("--jobs", type=int, default=max(1, min(2, multiprocessing.cpu_count())))
    ap.add_argument("--quick", action="store_true", help="fewer sizes and ticks (smoke run)")
    ap.add_argument("--replot", action="store_true",
                    help="redraw the plots from the JSON file (and rerun the Fig. 3 and Fig. 6 snapshots)")
    ap.add_argument("--d-s", type=float, default=None,
                    help="main experiment with this sensing range d_s < d_c (results under main_ds<value>, "
                         "plots roles-ds<value>-*.png)")
    ap.add_argument("--img", type=Path, default=ROOT / "docs/img")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "paper.json")
    args = ap.parse_args()
    args.img.mkdir(parents=True, exist_ok=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    results = json.loads(args.out.read_text()) if args.out.exists() else {}
    results["paper"] = PAPER
    results["machine"] = {"python": platform.python_version(), "cpus": multiprocessing.cpu_count(),
                          "platform": platform.platform(), "jobs": args.jobs,
                          "date": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    t0 = time.time()
    if args.replot:
        def ints(rows):
            for r in rows:
                if "cpu_s" in r:
                    r["cpu_s"] = {int(k): v for k, v in r["cpu_s"].items()}
            return rows
        if "preliminary" in results:
            fig3 = fig3_snapshot()
            plot_prelim(results["preliminary"]["rows"], args.img, fig3)
            results["preliminary"]["fig3"] = {k: v for k, v in fig3.items() if k != "pos"}
        if "main" in results:
            sweep = args.out.parent / "fig6-11_sweep.csv"  # the 30 trials per N, when saved beside the JSON
            plot_main(main_rows(sweep) if sweep.exists() else ints(results["main"]["rows"]), args.img)
            results["main"]["fig6"] = fig6_snapshots(args.img, ticks=results["main"]["ticks"])
        for key in [k for k in results if k.startswith("main_ds")]:
            plot_main(ints(results[key]["rows"]), args.img, prefix=f"roles-ds{results[key]['d_s']}")
        if "main" in results and "witnesses_all" in results:
            plot_fig7_witnesses(results["main"]["rows"], results["witnesses_all"]["rows"], args.img)
        args.out.write_text(json.dumps(results, indent=1, default=float))
        print(f"replotted from {args.out}")
        return
    if args.only in (None, "prelim"):
        ns = [10, 50, 100] if args.quick else list(range(10, 101, 10))
        ticks = 200 if args.quick else 1000
        print(f"preliminary: N = {ns}, {ticks} ticks, {args.trials} trials")
        rows = run_jobs(prelim_job, [(n, 1000 + s, ticks) for s in range(args.trials) for n in ns], args.jobs,
                        "preliminary")
        fig3 = fig3_snapshot()
        agg = plot_prelim(rows, args.img, fig3)
        results["preliminary"] = {"ticks": ticks, "trials": args.trials, "by_n": agg, "rows": rows,
                                  "fig3": {k: v for k, v in fig3.items() if k != "pos"}}
        for n, a in agg.items():
            print(f"  N={n:3d}: tests -{100 * a['tests_reduction']:.0f}%  wall {100 * -a['wall_reduction']:+.0f}%  "
                  f"lambda2 {a['proposed_lambda2']:.3f} vs {a['baseline_lambda2']:.3f} "
                  f"(-{100 * (a['lambda2_reduction'] or 0):.0f}%)")
    if args.only in (None, "main"):
        ns = [10, 30] if args.quick else [10, 20, 30, 40, 50]
        ticks = 500 if args.quick else 2000
        print(f"main: N = {ns}, {ticks} ticks, {args.trials} trials")
        params = {"d_s": args.d_s} if args.d_s else {}
        rows = run_jobs(main_job, [(n, 2000 + s, ticks, params) for s in range(args.trials) for n in ns], args.jobs,
                        "main")
        if args.d_s:
            agg = plot_main(rows, args.img, prefix=f"roles-ds{args.d_s}")
            results[f"main_ds{args.d_s}"] = {"ticks": ticks, "trials": args.trials, "d_s": args.d_s, "by_n": agg,
                                              "rows": rows}
        else:
            agg = plot_main(rows, args.img)
            fig6 = fig6_snapshots(args.img, ticks=ticks)
            results["main"] = {"ticks": ticks, "trials": args.trials, "by_n": agg, "rows": rows, "fig6": fig6}
        for n, a in agg.items():
            print(f"  N={n:2d}: targets {a['targets']:.1f}  disconnections {a['disconnections']:.1f} "
                  f"(mean {a['disconnection_mean']:.1f} ticks)  cpu/robot {a['cpu_s_per_robot']:.2f} s  "
                  f"msgs/robot/tick {a['received_per_tick']:.2f}  failed checks {a['checks_failed']}")
    if args.only == "triggers":
        ns = [int(x) for x in (args.sizes or "10,30,60,100").split(",")]
        ticks = 200 if args.quick else 1000
        print(f"triggers: N = {ns}, {ticks} ticks, {args.trials} trials")
        rows = run_jobs(triggers_job, [(n, 1000 + s, ticks) for s in range(args.trials) for n in ns], args.jobs,
                        "triggers")
        results["triggers"] = {"ticks": ticks, "trials": args.trials, "rows": sorted(rows, key=lambda r: r["n"])}
        for r in results["triggers"]["rows"]:
            p, nc, b = r["proposed"], r["no_circles"], r["baseline"]
            print(f"  N={r['n']:3d}: proposed {p['tests_per_robot']:.0f} tests/robot "
                  f"(-{100 * (1 - p['tests_per_robot'] / b['tests_per_robot']):.0f}% vs baseline) by trigger "
                  f"{ {k: round(v) for k, v in p['tests_by_trigger'].items()} }; without circles "
                  f"{nc['tests_per_robot']:.0f} (-{100 * (1 - nc['tests_per_robot'] / b['tests_per_robot']):.0f}%)"
                  f"; |A_i| < eta_c on {100 * p['below_eta_fraction']:.0f}% of calls, mean |A_i| "
                  f"{p['mean_degree_before']:.2f}, Gabriel degree (baseline) {b['mean_degree_before']:.2f}; "
                  f"lambda2 {p['lambda2']:.3f} / {nc['lambda2']:.3f} / {b['lambda2']:.3f}", flush=True)
    if args.only == "witnesses":
        ns = [int(x) for x in (args.sizes or "10,30,50").split(",")]
        ticks = 500 if args.quick else 2000
        params = {"witnesses": "all", **({"d_s": args.d_s} if args.d_s else {})}
        key = "witnesses_all" + (f"_ds{args.d_s}" if args.d_s else "")
        old = results.get(key, {})
        kept = [r for r in old.get("rows", []) if old.get("ticks") == ticks and old.get("params") == params]
        done = {(r["n"], r["seed"]) for r in kept}  # trials already run are kept, not run again
        todo = [(n, 2000 + s, ticks, params) for s in range(args.trials) for n in ns if (n, 2000 + s) not in done]
        print(f"patrol with the paper's witness set: N = {ns}, {ticks} ticks, {args.trials} trials, {params}; "
              f"{len(todo)} to run, {len(kept)} kept")
        rows = kept + run_jobs(main_job, todo, args.jobs, "witnesses")
        results[key] = {"ticks": ticks, "params": params, "rows": sorted(rows, key=lambda r: (r["n"], r["seed"])),
                        "sizes": sorted({r["n"] for r in rows}),
                        "trials": {str(n): sum(r["n"] == n for r in rows) for n in sorted({r["n"] for r in rows})}}
        if key == "witnesses_all" and "main" in results:
            plot_fig7_witnesses(results["main"]["rows"], results[key]["rows"], args.img)
        for r in results[key]["rows"]:
            print(f"  N={r['n']:2d} seed {r['seed']}: disconnections {r['disconnections']} (mean "
                  f"{r['disconnection_mean']:.1f}, max {r['disconnection_max']}), robot-ticks "
                  f"{r['disconnected_robot_ticks']}, targets {r['targets']}, checks {r['checks']}", flush=True)
    results["wall_s"] = round(time.time() - t0, 1)
    args.out.write_text(json.dumps(results, indent=1, default=float))
    print(f"wrote {args.out} and docs/img/roles-*.png in {results['wall_s']} s")


if __name__ == "__main__":
    main()

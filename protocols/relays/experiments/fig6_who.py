"""Swarm Relays, Fig. 6: who recruits, with and without WP, and the request routed to the base.

Runs the Fig. 6 time-factor condition (``fig6.sweep_trial``) for the given variants, numbers of targets
(``--T``, default 2), fields and trials, one run after another, and appends each run's row (time factor and
the behaviour's recruiting records, see ``fig6._who``) to a JSON-lines file; ``--summary`` prints, per T,
variant and field, the recruits by the recruiter's depth, the wait from request to join, how many other
recruits' slots (open to join) overlap each one (both chains) and the heads' stopped time, and each variant's
time factor against WP and against ``ask = "plan"`` of these rows and against the saved sweeps' rows of the
same placements (WP and the non-WP default from ``fig6_sweep.csv``, ``plan`` from ``fig6_ask_sweep.csv``;
Welch, 95 % CI of the difference).

    python -m protocols.relays.experiments.fig6_who --variants stretched,plan,wp --trials 0,1,2
    python -m protocols.relays.experiments.fig6_who --variants base --trials 0,1,2,3,4,5
    python -m protocols.relays.experiments.fig6_who --variants base --T 3,4 --trials 0,1,2,3,4,5
    python -m protocols.relays.experiments.fig6_who --summary [--trials 0,1,2,3,4,5]
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

import numpy as np

from protocols.relays.experiments.fig6 import diff_ci, mean_ci, sweep_trial

OUT = Path(__file__).resolve().parent / "results" / "fig6_who.jsonl"
VARIANTS = {  # name -> sweep parameters besides targets and obstacle
    "stretched": {"wp": False, "ask": "stretched"},
    "plan": {"wp": False, "ask": "plan"},
    "wp": {"wp": True},
    "base": {"wp": False, "ask": "plan", "route": "base"},
}


def run(variants: list[str], fields: list[bool], trials: list[int], out: Path = OUT,
        targets: list[int] = (2,)) -> None:
    for v in variants:
        for t in targets:
            for obstacle in fields:
                for trial in trials:
                    row = sweep_trial({"targets": t, "obstacle": obstacle, **VARIANTS[v]}, seed=0, trial=trial)
                    row["variant"] = v
                    with out.open("a") as f:
                        f.write(json.dumps(row) + "\n")
                    print(v, f"T={t}", "C" if obstacle else "open", trial, row.get("time_factor"), row["wall_s"],
                          flush=True)


def joined(row: dict) -> list[list]:
    """The slots that ended with a recruit in the chain (its child took it as parent)."""
    return [r for r in row["recruits"] if r[8] is not None]


def ask_outcomes(row: dict) -> Counter:
    """Each kept request (robot, depth) by what came of it.

    The robot's first slot opened within the request's 1 s window (recruit_time) joined, closed empty, or had a
    winner that did not join; or the robot opened no slot (one was still open, or it was not stretched in time).
    """
    out = Counter()
    for rid, t, depth, _up, _st in row["asks"]:
        slot = next((x for x in row["recruits"] if x[0] == rid and t - 1e-6 <= x[1] <= t + 1.0 + 1e-6), None)
        what = "no slot" if slot is None else ("joined" if slot[8] is not None else
                                               "empty" if slot[7] is None else "not joined")
        out[(depth, what)] += 1
    return out


def summary(rows: list[dict]) -> dict:
    """Per (variant, field): recruits by depth, waits, stops, time factors."""
    out = {}
    for key in sorted({(r["variant"], r["obstacle"]) for r in rows}):
        rs = sorted((r for r in rows if (r["variant"], r["obstacle"]) == key), key=lambda r: r["seed"])
        rec = [x for r in rs for x in joined(r)]
        asked = [x for x in rec if x[5] is not None]
        out[key] = {
            "runs": len(rs), "trials": [r["seed"] for r in rs],
            "tf": [r.get("time_factor") for r in rs],
            "recruits_per_run": len(rec) / len(rs),
            "by_depth": dict(sorted(Counter(x[2] for x in rec).items())),
            "root_share": sum(x[2] == 0 for x in rec) / max(1, len(rec)),
            "stretched_share": sum(bool(x[4]) for x in rec) / max(1, len(rec)),
            "request_to_join_s": float(np.median([x[8] - x[5] for x in asked])) if asked else None,
            "request_to_open_s": float(np.median([x[1] - x[5] for x in asked])) if asked else None,
            "open_to_join_s": float(np.median([x[8] - x[1] for x in rec])) if rec else None,
            "overlap": float(np.mean([sum(y[1] < x[8] and x[1] < y[8] for y in joined(r)) - 1
                                      for r in rs for x in joined(r)])) if rec else None,
            "unasked_share": sum(x[5] is None for x in rec) / max(1, len(rec)),
            "join_s_median": float(np.median([x[8] for x in rec])) if rec else None,
            "empty_slots_per_run": sum(x[7] is None for r in rs for x in r["recruits"]) / len(rs),
            "asks_kept_per_run": len([a for r in rs for a in r["asks"]]) / len(rs),
            "asks_kept_stretched": (sum(bool(a[4]) for r in rs for a in r["asks"])
                                    / max(1, sum(len(r["asks"]) for r in rs))),
            "asks_by_depth": dict(sorted(Counter(a[2] for r in rs for a in r["asks"]).items())),
            "ask_outcomes": {f"{d}:{w}": n for (d, w), n in
                             sorted(sum((ask_outcomes(r) for r in rs), Counter()).items())},
            "empty_by_depth": dict(sorted(Counter(x[2] for r in rs for x in r["recruits"] if x[7] is None).items())),
            "head_stopped_s": float(np.mean([s for r in rs for s in r["head_stopped_s"]])),
            "head_s": float(np.mean([s for r in rs for s in r["head_s"]])),
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", default="stretched,plan,wp")
    ap.add_argument("--fields", default="open,C")
    ap.add_argument("--trials", default=None, help="placements (default 0-5; with --summary: only these rows)")
    ap.add_argument("--T", default="2", help="numbers of targets, e.g. 3,4")
    ap.add_argument("--summary", action="store_true")
    a = ap.parse_args()
    if not a.summary:
        run(a.variants.split(","), [f == "C" for f in a.fields.split(",")],
            [int(t) for t in (a.trials or "0,1,2,3,4,5").split(",")], targets=[int(t) for t in a.T.split(",")])
        return
    rows = [json.loads(line) for line in OUT.open()]
    if a.trials:
        rows = [r for r in rows if r["seed"] in {int(t) for t in a.trials.split(",")}]
    for t in sorted({r.get("targets", 2) for r in rows}):
        s = summary([r for r in rows if r.get("targets", 2) == t])
        for (v, obst), d in s.items():
            print(f"T={t}", ("C" if obst else "open"), v, json.dumps(d))
        for obst in (False, True):
            for v in ("stretched", "plan", "base"):
                if (v, obst) not in s:
                    continue
                trials = s[(v, obst)]["trials"]
                refs = {**{f"{ref} (these rows)": s[(ref, obst)]["tf"] for ref in ("wp", "plan")
                           if ref != v and (ref, obst) in s},
                        **{f"{ref} (saved sweep)": xs for ref, xs in saved(t, obst, trials).items() if ref != v}}
                for ref, b_ in refs.items():
                    print(f"T={t}", "C" if obst else "open", v, "vs", ref, compare(s[(v, obst)]["tf"], b_))


def compare(a: list, b: list) -> str:
    """A's time factors against b's: both means with their 95 % CI and runs, a - b, its CI, % of b, Welch p."""
    a_, b_ = [x for x in a if x is not None], [x for x in b if x is not None]
    if len(a_) < 2 or len(b_) < 2:
        return f"too few runs ({len(a_)}/{len(a)}, {len(b_)}/{len(b)})"
    (ma, ha), (mb, hb) = mean_ci(a_), mean_ci(b_)
    d, h, p = diff_ci(a_, b_)
    return (f"{ma:.2f} ± {ha:.2f} ({len(a_)}/{len(a)}, sd {np.std(a_, ddof=1):.2f}) against {mb:.2f} ± {hb:.2f} "
            f"({len(b_)}/{len(b)}, sd {np.std(b_, ddof=1):.2f}): {d:+.2f} ± {h:.2f} ({100 * d / mb:+.0f} %), "
            f"Welch p = {p:.2g}")


def saved(targets: int, obstacle: bool, trials: list[int], results: Path = OUT.parent) -> dict[str, list]:
    """The saved sweeps' time factors of the same placements (trials), in the order of ``trials``.

    "wp" and "stretched" (the non-WP default) from ``fig6_sweep.csv``, "plan" from ``fig6_ask_sweep.csv`` (T = 2).
    """
    from swarmactors.tools.sweep import returned_values

    out: dict[str, dict[int, float | None]] = {}
    for name in ("fig6_sweep.csv", "fig6_ask_sweep.csv"):
        if not (results / name).exists():
            continue
        for r in returned_values(results / name):
            if r.get("kind") != "tf" or (r["targets"], r["obstacle"]) != (targets, obstacle):
                continue
            ref = "wp" if r["wp"] else (r.get("ask") or "stretched")
            out.setdefault(ref, {})[r["seed"]] = r.get("time_factor")
    return {ref: [by[t] for t in trials] for ref, by in out.items() if all(t in by for t in trials)}

if __name__ == "__main__":
    main()

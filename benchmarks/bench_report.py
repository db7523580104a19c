"""Reporting for benchmarks/bench.py: one table model, rendered with rich (terminal) or as Markdown (docs).

``tables(res)`` turns a results dict (what ``bench.py`` writes to JSON) into a list of ``Table``s; ``to_rich``
and ``to_markdown`` render the same list, so the terminal and docs/benchmarks.md never disagree. ``targets``
compares the results with the targets in docs/benchmarks.md, and ``chart`` draws robot-ticks/s against N.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

TARGETS = {
    "robot_ticks_per_s_n1000": 100_000,  # median, better of K = 0 and K = 2
    "robot_ticks_per_s_n10000": 30_000,
    "cost_ratio_n10000_vs_n100": 1.5,
    "emulator_over_raw_deliveries": 1.0,  # default callback
    "realtime_p99_error_ms": 2.0,
}


@dataclass
class Table:
    """A titled table of strings; ``numeric`` columns are right-aligned."""

    title: str
    columns: list[str]
    rows: list[list[str]] = field(default_factory=list)
    numeric: set[int] = field(default_factory=set)
    note: str = ""


def pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.0f}%"


def fmt(x: float | None, digits: int = 0) -> str:
    return "-" if x is None else f"{x:,.{digits}f}"


def _by(res: dict, behavior: str = "beacon") -> dict[tuple[int, int], dict]:
    return {(c["n"], c["k"]): c for c in res["lockstep"] if c.get("behavior", "beacon") == behavior}


def targets(res: dict) -> list[dict]:
    """Issue 21's targets against the medians of this run (a target whose case did not run is left out)."""
    by = _by(res)
    out = []
    best_k = [by[(1000, k)] for k in (0, 2) if (1000, k) in by]
    if best_k:
        top = max(best_k, key=lambda c: c["robot_ticks_per_s_median"])
        out.append({"target": f">= {TARGETS['robot_ticks_per_s_n1000']:,} robot-ticks/s at N = 1000 (median, "
                    "better of K = 0, 2)",
                    "measured": ", ".join(f"K={c['k']} {c['robot_ticks_per_s_median']:,.0f}" for c in best_k),
                    "met": top["robot_ticks_per_s_median"] >= TARGETS["robot_ticks_per_s_n1000"]})
    big = [c for (n, _), c in by.items() if n == 10_000]
    if big:
        top = max(c["robot_ticks_per_s_median"] for c in big)
        out.append({"target": f">= {TARGETS['robot_ticks_per_s_n10000']:,} robot-ticks/s at N = 10,000 (median)",
                    "measured": ", ".join(f"K={c['k']} {c['robot_ticks_per_s_median']:,.0f}" for c in big),
                    "met": top >= TARGETS["robot_ticks_per_s_n10000"]})
        ratios = {k: by[(10_000, k)]["us_per_robot_tick_median"] / by[(100, k)]["us_per_robot_tick_median"]
                  for (n, k) in by if n == 10_000 and (100, k) in by}
        if ratios:
            out.append({"target": f"cost per robot-tick N = 10,000 / N = 100 <= {TARGETS['cost_ratio_n10000_vs_n100']}x"
                        " (medians)", "measured": ", ".join(f"K={k}: {r:.2f}x" for k, r in ratios.items()),
                        "met": min(ratios.values()) <= TARGETS["cost_ratio_n10000_vs_n100"]})
    d = res.get("deliveries")
    if d and d.get("ratio") is not None:
        out.append({"target": f"emulator deliveries/s >= {TARGETS['emulator_over_raw_deliveries']}x raw Zenoh "
                    "(default callback, same run)", "measured": f"{d['ratio']:.2f}x ({d['emulator_case']}, median)",
                    "met": d["ratio"] >= TARGETS["emulator_over_raw_deliveries"]})
    if res.get("realtime"):
        p99 = res["realtime"][0]["error_ms"].get("p99", float("inf"))
        out.append({"target": "realtime p99 (latency - c) < 2 ms (N = 100, K = 0; best run)",
                    "measured": f"{p99:.2f} ms", "met": p99 < TARGETS["realtime_p99_error_ms"]})
    return out


def tables(res: dict) -> list[Table]:
    """Every table of a results dict, in the order they are printed and written to docs/benchmarks.md."""
    out: list[Table] = []
    m = res["machine"]
    t = Table("Machine", ["item", "value"])
    for key in ("nproc", "cpu_model", "python", "zenoh", "msgpack", "numpy", "platform", "date"):
        t.rows.append([key, str(m.get(key))])
    changes = m.get("worktree_changes")
    t.rows.append(["swarmactors", f"{m['swarmactors']['package']} at {str(m['swarmactors']['commit'])[:10]}"
                   + (f" with uncommitted changes in {len(changes)} file(s)" if changes else "")])
    t.rows.append(["mode", f"{res['config']['mode']}, {res['config']['repeats']} run(s) per case"])
    t.rows.append(["load average (start / end)",
                   f"{m['loadavg_start'][0]:.2f} / {m.get('loadavg_end', [0])[0]:.2f}"])
    out.append(t)

    reps = res["config"]["repeats"]
    t = Table(f"Lockstep beacon throughput: median and best of {reps} run(s) (wall time of the ticks only)",
              ["N", "K", "ticks", "robot-ticks/s median", "best", "µs / robot-tick (median)", "deliveries/s (median)",
               "deliveries / robot-tick", "world process CPU", "GC share of tick loop (world process)"],
              numeric=set(range(10)))
    for c in sorted(_by(res).values(), key=lambda c: (c["n"], c["k"])):
        t.rows.append([str(c["n"]), str(c["k"]), str(c["ticks"]), fmt(c["robot_ticks_per_s_median"]),
                       fmt(c["robot_ticks_per_s"]), fmt(c["us_per_robot_tick_median"], 1),
                       fmt(c["deliveries_per_s_median"]), fmt(c["deliveries_per_robot_tick"], 2),
                       pct(c["world_cpu_frac"]), pct(c["gc_share"])])
    out.append(t)

    idle = _by(res, "idle")
    if idle:
        beacon = _by(res)
        t = Table("The floor: robots that do nothing (idle) against beacon, same N and K (medians)",
                  ["N", "K", "idle robot-ticks/s", "idle µs / robot-tick", "beacon robot-ticks/s",
                   "beacon µs / robot-tick", "beacon − idle µs (the behaviour and its frames)"], numeric=set(range(7)))
        for (n, k), c in sorted(idle.items()):
            b = beacon.get((n, k))
            t.rows.append([str(n), str(k), fmt(c["robot_ticks_per_s_median"]), fmt(c["us_per_robot_tick_median"], 1),
                           fmt(b and b["robot_ticks_per_s_median"]), fmt(b and b["us_per_robot_tick_median"], 1),
                           fmt(b and b["us_per_robot_tick_median"] - c["us_per_robot_tick_median"], 1)])
        out.append(t)

    ns = sorted({n for n, _ in _by(res)})
    t = Table("Cost per robot-tick by N, µs (medians)", ["K", *[f"N = {n:,}" for n in ns], "largest N / N = 100"],
              numeric=set(range(len(ns) + 2)))
    by = _by(res)
    for k in sorted({k for _, k in by}):
        us = [by.get((n, k), {}).get("us_per_robot_tick_median") for n in ns]
        ratio = (by[(ns[-1], k)]["us_per_robot_tick_median"] / by[(100, k)]["us_per_robot_tick_median"]
                 if (100, k) in by and (ns[-1], k) in by else None)
        t.rows.append([str(k), *[fmt(u, 1) for u in us], "-" if ratio is None else f"{ratio:.2f}x"])
    out.append(t)

    d = res.get("deliveries")
    if d:
        t = Table("Deliveries per second: emulator against raw Zenoh (same payload, same run)",
                  ["what", "deliveries/s", "runs"], numeric={1})
        for label, raw in (("raw Zenoh pub/sub, 2 processes, default callback (`indirect=True`)", d["raw"]),
                           ("raw Zenoh pub/sub, callback on Zenoh's thread (`indirect=False`, as `transport.Link`)",
                            d["raw_indirect_false"])):
            t.rows.append([label, fmt(raw.get("msgs_per_s")), ", ".join(fmt(x) for x in raw["all_msgs_per_s"])])
        t.rows.append([f"emulator, {d['emulator_case']}", fmt(d["emulator_per_s"]), "median run"])
        t.rows.append(["**ratio emulator / raw (default callback)**", f"**{d['ratio']:.2f}**",
                       f"target >= {TARGETS['emulator_over_raw_deliveries']}"])
        t.rows.append(["ratio emulator / raw (`indirect=False`)", f"{d['ratio_vs_indirect_false']:.2f}", ""])
        out.append(t)

    if res.get("realtime"):
        t = Table(f"Realtime latency error (delivered latency − c), ms; c = 10 ms, dt = 50 ms, "
                  f"{res['config']['realtime_s']:g} s per run; the run with the lowest p99",
                  ["N", "K", "samples", "p50", "p90", "p99", "max", "min", "uplink p50", "uplink p99",
                   "p99 of every run"], numeric=set(range(10)))
        for c in res["realtime"]:
            e, u = c["error_ms"], c["uplink_ms"]
            t.rows.append([str(c["n"]), str(c["k"]), fmt(c["samples"]), fmt(e.get("p50"), 2), fmt(e.get("p90"), 2),
                           fmt(e.get("p99"), 2), fmt(e.get("max"), 2), fmt(e.get("min"), 2), fmt(u.get("p50"), 2),
                           fmt(u.get("p99"), 2), ", ".join(fmt(x, 1) for x in c["p99_all_runs_ms"])])
        out.append(t)

    p = res.get("profile", {}).get("k0")
    if p:
        t = Table(f"cProfile, N = {p['n']}, K = 0, {p['ticks']} ticks: top functions by own time "
                  f"({p['profiled_s']:.2f} s profiled, wall {p['wall_s_under_profile']:.2f} s)",
                  ["function", "calls", "own s", "share", "cumulative s"], numeric={1, 2, 3, 4})
        for r in p["top_tottime"][:12]:
            t.rows.append([f"`{r['function']}`", fmt(r["calls"]), f"{r['tottime_s']:.3f}", f"{100 * r['share']:.1f}%",
                           f"{r['cumtime_s']:.3f}"])
        out.append(t)
        t = Table("cProfile, N = 1000, K = 0: cumulative time by stage (indented: inside the one above)",
                  ["stage", "s"], numeric={1})
        t.rows += [[k, f"{v:.3f}"] for k, v in p["stages"].items()]
        out.append(t)
    k2 = res.get("profile", {}).get("k2")
    if k2:
        t = Table(f"cProfile, N = {k2['n']}, K = 2, {k2['ticks']} ticks: time each process runs its tick loop "
                  f"(wall {k2['wall_s_under_profile']:.2f} s under profile)", ["process", "busy s", "share of wall"],
                  numeric={1, 2})
        t.rows.append(["world", f"{k2['world_busy_s']:.2f}", pct(k2["world_busy_frac"])])
        t.rows += [[f"host {i}", f"{b:.2f}", pct(f)]
                   for i, (b, f) in enumerate(zip(k2["host_busy_s"], k2["host_busy_frac"], strict=True))]
        out.append(t)

    t = Table("Targets (docs/benchmarks.md)", ["target", "measured", "met"])
    t.rows += [[r["target"], r["measured"], "yes" if r["met"] else "**no**"] for r in res.get("targets", [])]
    out.append(t)
    return out


def to_rich(tabs: list[Table], console) -> None:
    """Print the tables on a rich console."""
    from rich.table import Table as RichTable

    for tab in tabs:
        rt = RichTable(title=tab.title)
        for i, col in enumerate(tab.columns):
            rt.add_column(col, justify="right" if i in tab.numeric else "left")
        for row in tab.rows:
            rt.add_row(*[cell.replace("**", "").replace("`", "") for cell in row])
        console.print(rt)


def to_markdown(tabs: list[Table]) -> str:
    """The tables as Markdown sections (``### title``, then a pipe table), for docs/benchmarks.md."""
    out: list[str] = []
    for tab in tabs:
        out += [f"#### {tab.title}", ""]
        out.append("| " + " | ".join(tab.columns) + " |")
        out.append("|" + "|".join("---:" if i in tab.numeric else "---" for i in range(len(tab.columns))) + "|")
        out += ["| " + " | ".join(row) + " |" for row in tab.rows]
        out.append("")
    return "\n".join(out)


def chart(res: dict, path: Path) -> Path | None:
    """Robot-ticks/s (median) against N for each K, log-log, with the raw-Zenoh equivalent of the same run.

    The raw-Zenoh line is the raw rate (one put per (frame, receiver), default callback) divided by the beacon's
    deliveries per robot-tick at each N: the robot-ticks/s a run would reach if each delivery cost one raw
    Zenoh message and nothing else.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by = _by(res)
    if not by:
        return None
    fig, ax = plt.subplots(figsize=(7, 5))
    for k in sorted({k for _, k in by}):
        pts = sorted((n, c["robot_ticks_per_s_median"]) for (n, kk), c in by.items() if kk == k)
        ax.plot([n for n, _ in pts], [v for _, v in pts], marker="o", label=f"beacon, K = {k}")
    idle = _by(res, "idle")
    for (n, k), c in sorted(idle.items()):
        ax.plot([n], [c["robot_ticks_per_s_median"]], marker="^", linestyle="none", color="grey",
                label="idle (the floor)" if (n, k) == min(idle) else None)
    raw = (res.get("deliveries") or {}).get("raw", {}).get("msgs_per_s")
    if raw:
        per = {}
        for (n, _), c in by.items():
            per.setdefault(n, c["deliveries_per_robot_tick"])
        pts = sorted((n, raw / d) for n, d in per.items() if d)
        ax.plot([n for n, _ in pts], [v for _, v in pts], linestyle="--", color="black",
                label="raw Zenoh (one put per delivery), same run")
    ax.set_xscale("log")
    ax.set_yscale("log")
    for name, target in (("target at N = 1000", TARGETS["robot_ticks_per_s_n1000"]),
                         ("target at N = 10,000", TARGETS["robot_ticks_per_s_n10000"])):
        ax.axhline(target, color="red", linewidth=0.6, linestyle=":")
        ax.text(0.01, target, name, transform=ax.get_yaxis_transform(), fontsize=7, color="red", va="bottom")
    ax.set_xlabel("robots N")
    ax.set_ylabel("robot-ticks per second (median)")
    m = res["machine"]
    ax.set_title(f"Lockstep beacon, {m['nproc']} cores, load {m['loadavg_start'][0]:.1f} at start "
                 f"({res['config']['mode']})", fontsize=9)
    ax.grid(True, which="both", linewidth=0.3)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path

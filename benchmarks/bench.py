#!/usr/bin/env python
"""swarmactors benchmarks: one command, one run, one table, one JSON file.

    python benchmarks/bench.py [--quick] [--out benchmarks/results.json]

Measures on this machine (docs/benchmarks.md explains each number):

1. lockstep throughput: robot-ticks per second of the beacon workload
   (scenarios/beacon.toml: every robot broadcasts one small frame per tick,
   grid placement, ~8 neighbours each) at N = 10, 100, 1000 with K = 0 and
   K = 2 robot-host processes, through ``swarmactors.launcher.run_world``;
2. how the cost per robot-tick grows from N = 10 to N = 1000;
3. deliveries per second: the emulator's (N = 1000, K = 2) against raw Zenoh
   pub/sub between two spawned processes, one message per (frame, receiver),
   same payload size, same run;
4. realtime latency error: N = 100 beacons of ``latency_probe`` in the
   realtime clock, c = 10 ms: the distribution of (delivered latency - c);
5. where the time goes: cProfile of one N = 1000 lockstep run (K = 0), the
   world and host processes of one N = 1000 K = 2 run, and the garbage
   collector's share of the world process's tick loop (every run is measured
   with the collector as the product sets it: ``hosting.quiet_gc``).

Every case runs ``--repeats`` times (3; 1 with ``--quick``), round-robin
over the cases so that a burst of other load spreads over all of them. The
headline is the best run, the one least disturbed by other work on the
machine (as ``timeit`` reports the minimum); the median is shown beside it,
every run and the load average before it are in the JSON.

Nothing here is asserted: the numbers are recorded, the targets are printed
next to them.
"""

from __future__ import annotations

import argparse
import asyncio
import cProfile
import gc
import json
import multiprocessing as mp
import os
import platform
import pstats
import queue
import sys
import tempfile
import threading
import time
import uuid
from contextlib import contextmanager
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
if str(HERE) not in sys.path:  # latency_probe; spawned hosts inherit sys.path
    sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402
import zenoh  # noqa: E402
from rich.console import Console  # noqa: E402
from rich.table import Table  # noqa: E402

from swarmactors import launcher, scenario  # noqa: E402
from swarmactors.result import package_version  # noqa: E402
from transport import Endpoints, make_config, pack  # noqa: E402

BEACON = ROOT / "scenarios" / "beacon.toml"
PROBE = "latency_probe:LatencyProbe"

TARGETS = {
    "robot_ticks_per_s_n1000": 20_000,
    "cost_ratio_n1000_vs_n10": 1.5,
    "emulator_over_raw_deliveries": 1.0,
    "realtime_p99_error_ms": 2.0,
}

# ticks per case: each full case runs a few seconds on a 2-core machine
FULL = {
    "repeats": 3,
    "ticks": {10: 3000, 100: 300, 1000: 40},
    "profile_ticks": 30,
    "raw_s": 3.0,
    "realtime_s": 4.0,
    "k2_profile": True,
}
QUICK = {
    "repeats": 1,
    "ticks": {10: 600, 100: 60, 1000: 10},
    "profile_ticks": 8,
    "raw_s": 1.5,
    "realtime_s": 2.0,
    "k2_profile": False,
}

console = Console()
if console.width < 150 and not console.is_terminal:
    console = Console(width=150)


# --------------------------------------------------------------------------- machine
def machine() -> dict:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass

    def ver(dist: str) -> str | None:
        try:
            return version(dist)
        except PackageNotFoundError:
            return None

    try:
        affinity = len(os.sched_getaffinity(0))
    except AttributeError:
        affinity = None
    return {
        "nproc": affinity or os.cpu_count(),
        "cpu_count": os.cpu_count(),
        "cpu_model": cpu,
        "platform": platform.platform(),
        "python": platform.python_version(),
        "python_impl": platform.python_implementation(),
        "zenoh": ver("eclipse-zenoh"),
        "msgpack": ver("msgpack"),
        "numpy": ver("numpy"),
        "scipy": ver("scipy"),
        "swarmactors": package_version(),
        "worktree_changes": git_changes(),
        "loadavg_start": list(os.getloadavg()),
        "date": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }


def git_changes() -> list[str] | None:
    """Uncommitted changes in the source tree measured (``git status --porcelain``)."""
    import subprocess

    try:
        out = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=10,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.splitlines() if out.returncode == 0 else None


# --------------------------------------------------------------------------- emulator runs
class GcMeter:
    """Wall time spent in this process's garbage collector (all generations).

    Every collection is kept as (start, seconds, generation), so that the
    share of one window (the tick loop) can be told apart from the explicit
    ``gc.collect()`` that ``hosting.quiet_gc`` makes before the run starts.
    """

    def __init__(self) -> None:
        self.seconds = 0.0
        self.collections = [0, 0, 0]
        self.gen2_seconds = 0.0
        self.events: list[tuple[float, float, int]] = []
        self._t0 = 0.0

    def __call__(self, phase: str, info: dict) -> None:
        if phase == "start":
            self._t0 = time.perf_counter()
        else:
            dt = time.perf_counter() - self._t0
            self.seconds += dt
            self.collections[info["generation"]] += 1
            self.events.append((self._t0, dt, info["generation"]))
            if info["generation"] == 2:
                self.gen2_seconds += dt

    def within(self, t0: float, t1: float) -> tuple[float, list[int]]:
        """GC seconds and collections per generation that started in [t0, t1]."""
        secs, counts = 0.0, [0, 0, 0]
        for start, dt, gen in self.events:
            if t0 <= start <= t1:
                secs += dt
                counts[gen] += 1
        return secs, counts

    @contextmanager
    def measuring(self):
        gc.callbacks.append(self)
        try:
            yield self
        finally:
            gc.callbacks.remove(self)


def load_beacon(n: int, ticks: int, extra: list[str] = ()) -> dict:
    return scenario.load(BEACON, overrides=[f"robots.0.count={n}", f"run.ticks={ticks}", "run.trace=false", *extra])


def run_emulator(sc: dict, k: int, on_open=None, local_host: bool = True, on_tick=None) -> tuple[dict, dict]:
    """Run a resolved scenario through the Python API; return (result.json data, process meters)."""
    meter = GcMeter()
    with tempfile.TemporaryDirectory(prefix="swarmbench-") as d, meter.measuring():
        t0 = time.perf_counter()
        c0 = time.process_time()
        result = asyncio.run(
            launcher.run_world(
                sc,
                Path(d),
                Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                launcher.new_run_id(f"bench-{sc['run']['name']}"),
                processes=k,
                local_host=local_host,
                on_open=on_open,
                on_tick=on_tick,
            )
        )
        total = time.perf_counter() - t0
        cpu = time.process_time() - c0
    data = result.data
    meters = {
        "total_s": total,  # including host start-up, join and reports
        "bench_process_cpu_s": cpu,  # world (+ K=0 robots), all threads, whole run_world call
        "gc_s": meter.seconds,  # whole call: includes quiet_gc's gc.collect() before the run
        "gc_gen2_s": meter.gen2_seconds,
        "gc_collections": meter.collections,
        "gc": meter,
    }
    return data, meters


def check_run(data: dict, n: int, ticks: int) -> list[str]:
    problems = []
    if data["ticks"] != ticks:
        problems.append(f"ran {data['ticks']} of {ticks} ticks ({data['stop_reason']})")
    failed = [rid for rid, r in data["robots"].items() if r["failed"]]
    if failed:
        problems.append(f"{len(failed)} robots failed, e.g. {data['robots'][failed[0]]['failed']}")
    if data["world"]["dropped_total"]:
        problems.append(f"{data['world']['dropped_total']} frames dropped: {data['world']['dropped']}")
    if len(data["robots"]) != n:
        problems.append(f"{len(data['robots'])} robots, expected {n}")
    return problems


def lockstep_run(n: int, k: int, ticks: int) -> dict:
    """One lockstep beacon run; rates over the world's tick loop only (``wall_s``)."""
    sc = load_beacon(n, ticks)
    stamps: list[tuple[float, float]] = []

    def on_tick(world) -> None:  # world-process CPU use while ticking (first and last tick)
        stamp = (time.perf_counter(), time.process_time())
        if len(stamps) < 2:
            stamps.append(stamp)
        else:
            stamps[1] = stamp

    load = os.getloadavg()[0]
    data, meters = run_emulator(sc, k, on_tick=on_tick)
    wall = data["wall_s"]
    rt = n * data["ticks"]
    cpu_frac = gc_share = None
    gc_loop_s, gc_loop_collections = 0.0, [0, 0, 0]
    if len(stamps) == 2 and stamps[1][0] > stamps[0][0]:
        span = stamps[1][0] - stamps[0][0]
        cpu_frac = (stamps[1][1] - stamps[0][1]) / span
        # the collector's share of the tick loop (first to last tick), in the world process
        gc_loop_s, gc_loop_collections = meters["gc"].within(stamps[0][0], stamps[1][0])
        gc_share = gc_loop_s / span
    return {
        "wall_s": wall,
        "robot_ticks": rt,
        "robot_ticks_per_s": rt / wall,
        "us_per_robot_tick": 1e6 * wall / rt,
        "deliveries": data["world"]["deliveries"],
        "deliveries_per_s": data["world"]["deliveries"] / wall,
        "frames_sent": data["world"]["frames_sent"],
        "world_cpu_frac": cpu_frac,
        "gc_share_tick_loop": gc_share,
        "gc_tick_loop_s": gc_loop_s,
        "gc_tick_loop_collections": gc_loop_collections,
        "gc_whole_call_s": meters["gc_s"],
        "gc_whole_call_collections": meters["gc_collections"],
        "total_s": meters["total_s"],
        "loadavg_1m_before": load,
        "problems": check_run(data, n, ticks),
    }


def aggregate(n: int, k: int, ticks: int, runs: list[dict]) -> dict:
    """One case over its repeats: the best run (least disturbed by other load) and the median."""
    ordered = sorted(runs, key=lambda r: r["robot_ticks_per_s"])
    med, best = ordered[len(runs) // 2], ordered[-1]
    return {
        "n": n,
        "k": k,
        "ticks": ticks,
        "repeats": len(runs),
        "robot_ticks_per_s": best["robot_ticks_per_s"],
        "robot_ticks_per_s_median": med["robot_ticks_per_s"],
        "robot_ticks_per_s_min": ordered[0]["robot_ticks_per_s"],
        "us_per_robot_tick": best["us_per_robot_tick"],
        "us_per_robot_tick_median": med["us_per_robot_tick"],
        "deliveries_per_s": best["deliveries_per_s"],
        "deliveries_per_s_median": med["deliveries_per_s"],
        "deliveries_per_robot_tick": best["deliveries"] / best["robot_ticks"],
        "wall_s": best["wall_s"],
        "gc_share": best["gc_share_tick_loop"],
        "world_cpu_frac": best["world_cpu_frac"],
        "runs": runs,
    }


# --------------------------------------------------------------------------- raw Zenoh
RAW_END = b"END"


def _raw_subscriber(key: str, ready: mp.Queue, out: mp.Queue, done, indirect: bool) -> None:
    """Listen on an ephemeral loopback port, count every sample on ``key``, report the rate.

    ``indirect=True`` is zenoh-python's default callback mode (samples handed to
    one Python thread); ``indirect=False`` runs the callback on Zenoh's own
    thread, as ``transport.Link`` does.
    """
    session = zenoh.open(make_config(Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"])))
    state = {"n": 0, "first": None, "last": None, "bytes": 0}
    finished = threading.Event()

    def on_sample(sample: zenoh.Sample) -> None:
        data = sample.payload.to_bytes()
        now = time.perf_counter()
        if data == RAW_END:
            finished.set()
            return
        if state["first"] is None:
            state["first"] = now
        state["n"] += 1
        state["bytes"] += len(data)
        state["last"] = now

    sub = session.declare_subscriber(key, zenoh.handlers.Callback(on_sample, indirect=indirect))
    zid = str(session.zid())
    locators = []
    for reply in session.get(f"@/{zid}/peer", timeout=5.0):
        if reply.ok is not None:
            locators = json.loads(reply.ok.payload.to_bytes()).get("locators", [])
    ready.put(locators[0])
    ok = finished.wait(120.0)
    n, first, last = state["n"], state["first"], state["last"]
    span = (last - first) if n > 1 else float("nan")
    out.put(
        {
            "received": n,
            "bytes": state["bytes"],
            "span_s": span,
            "msgs_per_s": (n - 1) / span if n > 1 and span > 0 else None,
            "finished": ok,
        }
    )
    done.set()
    sub.undeclare()
    session.close()


def _raw_publisher(key: str, locator: str, payload: bytes, seconds: float, out: mp.Queue, done) -> None:
    """Connect to the subscriber and put ``payload`` as fast as possible for ``seconds``."""
    session = zenoh.open(make_config(Endpoints(mode="peer", connect=[locator])))
    pub = session.declare_publisher(
        key, congestion_control=zenoh.CongestionControl.BLOCK, reliability=zenoh.Reliability.RELIABLE
    )
    deadline = time.monotonic() + 30.0
    while not pub.matching_status.matching:
        if time.monotonic() > deadline:
            out.put({"error": "no matching subscriber within 30 s"})
            return
        time.sleep(0.01)
    time.sleep(0.2)
    sent = 0
    put = pub.put
    t0 = time.perf_counter()
    stop = t0 + seconds
    while time.perf_counter() < stop:
        for _ in range(1000):
            put(payload)
        sent += 1000
    elapsed = time.perf_counter() - t0
    put(RAW_END)
    out.put({"sent": sent, "publish_s": elapsed, "put_per_s": sent / elapsed})
    done.wait(120.0)  # closing the session early would drop what is still queued
    pub.undeclare()
    session.close()


def raw_zenoh(seconds: float, payload: bytes, indirect: bool = True) -> dict:
    """Raw Zenoh pub/sub between two spawned processes over a peer-to-peer TCP loopback link."""
    ctx = mp.get_context("spawn")
    key = f"swarmbench/raw/{uuid.uuid4().hex[:8]}"
    ready, sub_out, pub_out, done = ctx.Queue(), ctx.Queue(), ctx.Queue(), ctx.Event()
    sub = ctx.Process(target=_raw_subscriber, args=(key, ready, sub_out, done, indirect), daemon=True)
    sub.start()
    procs = [sub]
    p: dict = {}
    s: dict = {}
    try:
        locator = ready.get(timeout=60)
        pub = ctx.Process(target=_raw_publisher, args=(key, locator, payload, seconds, pub_out, done), daemon=True)
        pub.start()
        procs.append(pub)
        p = pub_out.get(timeout=seconds + 90)
        s = sub_out.get(timeout=seconds + 90)
    except queue.Empty:
        console.log("[red]raw Zenoh: no answer from the publisher or subscriber process")
        p = p or {"error": "no report"}
        s = s or {"error": "no report", "received": 0}
    for proc in procs:
        proc.join(10)
        if proc.is_alive():
            proc.kill()
    return {
        "payload_bytes": len(payload),
        "indirect": indirect,
        "publisher": p,
        "subscriber": s,
        "msgs_per_s": s.get("msgs_per_s"),
        "lost": p.get("sent", 0) - s.get("received", 0),
    }


def beacon_body_size() -> int:
    """Bytes of one beacon frame body as protocols/beacon.py sends it in lockstep."""
    return len(pack([1.0, b"\x00" * 8]))


# --------------------------------------------------------------------------- realtime
def realtime_case(n: int, k: int, seconds: float) -> dict:
    dt, c = 0.05, 0.01
    sc = scenario.load(
        BEACON,
        overrides=[
            f"robots.0.count={n}",
            'run.clock="realtime"',
            f"run.dt={dt}",
            f"run.ticks={int(seconds / dt)}",
            f"radio.latency_s={c}",
            "run.trace=false",
            f'robots.0.behaviors=[{{use = "{PROBE}"}}]',
        ],
    )
    data, meters = run_emulator(sc, k)
    delays, uplink, mono = [], [], []
    for r in data["robots"].values():
        rep = r.get("latency_probe") or {}
        delays += rep.get("delays", [])
        uplink += rep.get("uplink", [])
        mono += rep.get("delays_mono", [])
    err_ms = (np.array(delays) - c) * 1e3
    up_ms = np.array(uplink) * 1e3
    call_ms = (np.array(mono) - c) * 1e3  # from the broadcast call to on_frame, one monotonic clock

    def dist(a: np.ndarray) -> dict:
        if not a.size:
            return {}
        q = np.percentile(a, [50, 90, 99])
        return {
            "p50": float(q[0]),
            "p90": float(q[1]),
            "p99": float(q[2]),
            "max": float(a.max()),
            "min": float(a.min()),
            "mean": float(a.mean()),
        }

    return {
        "n": n,
        "k": k,
        "dt": dt,
        "c_s": c,
        "ticks": data["ticks"],
        "wall_s": data["wall_s"],
        "samples": int(err_ms.size),
        "deliveries": data["world"]["deliveries"],
        "error_ms": dist(err_ms),
        "call_ms": dist(call_ms),
        "uplink_ms": dist(up_ms),
        "rest_ms": dist(err_ms - up_ms),
        "problems": check_run(data, n, data["ticks"]),
    }


# --------------------------------------------------------------------------- profiles
def _component(file: str, func: str) -> str:
    f = file.replace("\\", "/")
    if "select.epoll" in func or "selectors" in f:
        return "waiting (epoll: Zenoh round trips, other processes)"
    for part, name in (
        ("/world/", "world/ (tick loop, radio, sensing)"),
        ("/swarmactors/host.py", "swarmactors/host.py (robot host)"),
        ("/swarmactors/behavior.py", "swarmactors/behavior.py (context)"),
        ("/swarmactors/trace.py", "swarmactors/trace.py (trace hash)"),
        ("/transport/", "transport/ (codec, link)"),
        ("/protocols/", "protocols/ (beacon behaviour)"),
        ("/msgpack/", "msgpack"),
        ("/asyncio/", "asyncio"),
        ("/numpy/", "numpy"),
        ("/scipy/", "scipy"),
    ):
        if part in f:
            return name
    if "numpy" in func:
        return "numpy"
    if "zenoh" in func or "Session" in func or "Query" in func:
        return "zenoh (Python bindings)"
    if f == "~":
        return "builtins (list/dict/sort/...)"
    return "other Python"


def summarise_profile(stats: pstats.Stats, top: int = 15) -> dict:
    raw = stats.stats  # (file, line, func) -> (cc, nc, tt, ct, callers)
    total = sum(v[2] for v in raw.values())
    rows = sorted(raw.items(), key=lambda kv: kv[1][2], reverse=True)[:top]

    def label(key) -> str:
        file, line, func = key
        if file == "~":
            return func
        rel = file.replace(str(ROOT) + "/", "")
        if "site-packages/" in rel:
            rel = rel.split("site-packages/", 1)[1]
        elif "/lib/python3" in rel:
            rel = "stdlib/" + rel.split("/lib/python3", 1)[1].split("/", 1)[1]
        return f"{rel}:{line}({func})"

    comps: dict[str, float] = {}
    for (file, _, func), v in raw.items():
        c = _component(file, func)
        comps[c] = comps.get(c, 0.0) + v[2]

    def cum(file_end: str, func: str) -> float:
        return sum(v[3] for (f, _, fn), v in raw.items() if f.endswith(file_end) and fn == func)

    return {
        "profiled_s": total,
        "top_tottime": [
            {
                "function": label(k),
                "calls": v[1],
                "tottime_s": round(v[2], 4),
                "cumtime_s": round(v[3], 4),
                "share": v[2] / total,
            }
            for k, v in rows
        ],
        "components": dict(sorted(((k, round(s, 4)) for k, s in comps.items()), key=lambda kv: -kv[1])),
        "stages": {
            "World._run_lockstep": cum("world/world.py", "_run_lockstep"),
            "  World._deliver_due": cum("world/world.py", "_deliver_due"),
            "  World._inputs_for": cum("world/world.py", "_inputs_for"),
            "  World._begin_tick": cum("world/world.py", "_begin_tick"),
            "  World._end_tick": cum("world/world.py", "_end_tick"),
            "  World._absorb": cum("world/world.py", "_absorb"),
            "World._on_step_query": cum("world/world.py", "_on_step_query"),
            "RobotHost._run_lockstep": cum("swarmactors/host.py", "_run_lockstep"),
            "  RobotHost._step_lockstep": cum("swarmactors/host.py", "_step_lockstep"),
            "msgpack unpack, all callers (transport.codec.unpack)": cum("transport/codec.py", "unpack"),
            "msgpack pack, all callers (transport.codec.pack)": cum("transport/codec.py", "pack"),
        },
    }


def profile_k0(n: int, ticks: int) -> dict:
    sc = load_beacon(n, ticks)
    prof = cProfile.Profile()
    meter = GcMeter()
    with tempfile.TemporaryDirectory(prefix="swarmbench-") as d, meter.measuring():
        prof.enable()
        result = asyncio.run(
            launcher.run_world(
                sc,
                Path(d),
                Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                launcher.new_run_id("bench-profile"),
                processes=0,
            )
        )
        prof.disable()
    out = summarise_profile(pstats.Stats(prof))
    out.update(
        {
            "n": n,
            "k": 0,
            "ticks": ticks,
            "wall_s_under_profile": result.data["wall_s"],
            "gc_s_under_profile": meter.seconds,
        }
    )
    return out


def _profiled_host(endpoint: str, run_id: str, count: int, path: str) -> None:
    prof = cProfile.Profile()
    prof.enable()
    try:
        launcher.host_process(endpoint, run_id, count)
    finally:
        prof.disable()
        prof.dump_stats(path)


def profile_k2(n: int, ticks: int) -> dict:
    """Profile the world process and both host processes of one N-robot K=2 run (cProfile)."""
    sc = load_beacon(n, ticks)
    ctx = mp.get_context("spawn")
    procs: list = []
    run_id = launcher.new_run_id("bench-profile-k2")
    with tempfile.TemporaryDirectory(prefix="swarmbench-prof-") as pdir:
        paths = [str(Path(pdir) / f"host{i}.prof") for i in range(2)]

        def on_open(world, link) -> None:
            endpoint = link.locators()[0]
            for count, path in zip(launcher.split(n, 2), paths, strict=True):
                p = ctx.Process(target=_profiled_host, args=(endpoint, run_id, count, path), daemon=True)
                p.start()
                procs.append(p)

        prof = cProfile.Profile()
        with tempfile.TemporaryDirectory(prefix="swarmbench-") as d:
            prof.enable()
            result = asyncio.run(
                launcher.run_world(
                    sc,
                    Path(d),
                    Endpoints(mode="peer", listen=["tcp/127.0.0.1:0"]),
                    run_id,
                    processes=0,
                    local_host=False,
                    on_open=on_open,
                )
            )
            prof.disable()
        for p in procs:
            p.join(30)
        world = summarise_profile(pstats.Stats(prof), top=10)
        hosts = [summarise_profile(pstats.Stats(p), top=10) for p in paths if Path(p).exists()]
    wall = result.data["wall_s"]

    # busy = time running the tick loop's own code (coroutine time counts only while resumed)
    world_busy = world["stages"]["World._run_lockstep"] + world["stages"]["World._on_step_query"]
    host_busy = [h["stages"]["RobotHost._run_lockstep"] for h in hosts]
    return {
        "n": n,
        "k": 2,
        "ticks": ticks,
        "wall_s_under_profile": wall,
        "world_busy_s": world_busy,
        "host_busy_s": host_busy,
        "world_busy_frac": world_busy / wall,
        "host_busy_frac": [b / wall for b in host_busy],
        "world": world,
        "hosts": hosts,
    }


# --------------------------------------------------------------------------- report
def pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.0f}%"


def fmt(x: float | None, digits: int = 0) -> str:
    if x is None:
        return "-"
    return f"{x:,.{digits}f}"


def print_tables(res: dict) -> None:
    m = res["machine"]
    t = Table(title="Machine")
    t.add_column("item")
    t.add_column("value")
    for key in ("nproc", "cpu_model", "python", "zenoh", "msgpack", "numpy", "platform"):
        t.add_row(key, str(m[key]))
    t.add_row("swarmactors", f"{m['swarmactors']['package']} @ {str(m['swarmactors']['commit'])[:10]}")
    t.add_row("load average (start / end)", f"{m['loadavg_start'][0]:.2f} / {m.get('loadavg_end', [0])[0]:.2f}")
    console.print(t)

    t = Table(
        title=f"Lockstep beacon throughput, best and median of {res['config']['repeats']} runs "
        "(wall time of the ticks only; other columns from the best run)"
    )
    for col in (
        "N",
        "K",
        "ticks",
        "robot-ticks/s best",
        "median",
        "us/robot-tick",
        "deliveries/s",
        "deliv. per robot-tick",
        "world proc CPU",
        "GC share of tick loop (world proc)",
    ):
        t.add_column(col, justify="right")
    for c in res["lockstep"]:
        t.add_row(
            str(c["n"]),
            str(c["k"]),
            str(c["ticks"]),
            fmt(c["robot_ticks_per_s"]),
            fmt(c["robot_ticks_per_s_median"]),
            fmt(c["us_per_robot_tick"], 1),
            fmt(c["deliveries_per_s"]),
            fmt(c["deliveries_per_robot_tick"], 2),
            pct(c["world_cpu_frac"]),
            pct(c["gc_share"]),
        )
    console.print(t)

    t = Table(title="Cost per robot-tick, N = 1000 vs N = 10 (best runs; median-run ratio in the last column)")
    for col in ("K", "us/robot-tick N=10", "N=100", "N=1000", "ratio 1000/10", "target", "median-run ratio"):
        t.add_column(col, justify="right")
    for k, s in res["scaling"].items():
        t.add_row(
            k,
            fmt(s["us"]["10"], 1),
            fmt(s["us"]["100"], 1),
            fmt(s["us"]["1000"], 1),
            f"{s['ratio_1000_vs_10']:.2f}x",
            f"<= {TARGETS['cost_ratio_n1000_vs_n10']}x",
            f"{s['ratio_1000_vs_10_median']:.2f}x",
        )
    console.print(t)

    d = res["deliveries"]
    t = Table(title="Deliveries per second: emulator vs raw Zenoh (same payload, same run)")
    for col in ("what", "deliveries/s", "notes"):
        t.add_column(col)
    for label, raw in (
        ("raw Zenoh, 2 processes, default callback", d["raw"]),
        ("raw Zenoh, callback on Zenoh thread", d["raw_indirect_false"]),
    ):
        t.add_row(
            label,
            fmt(raw["msgs_per_s"]),
            f"{raw['payload_bytes']} B payload, BLOCK, {raw['subscriber'].get('received', 0):,} received, "
            f"{raw['lost']} lost, best of " + " ".join(fmt(x) for x in raw["all_msgs_per_s"]),
        )
    t.add_row(
        "emulator, N=1000 K=2 lockstep", fmt(d["emulator_per_s"]), "(frame, receiver) pairs per wall second, best run"
    )
    t.add_row(
        "ratio emulator / raw (default callback)",
        f"{d['ratio']:.2f}",
        f"target >= {TARGETS['emulator_over_raw_deliveries']}",
    )
    t.add_row("ratio emulator / raw (indirect=False)", f"{d['ratio_vs_indirect_false']:.2f}", "")
    console.print(t)

    t = Table(
        title=f"Realtime latency error (delivered latency - c) in ms, c = 10 ms, dt = 50 ms: the run with the "
        f"lowest p99 of {res['config']['repeats']}"
    )
    for col in (
        "N",
        "K",
        "samples",
        "p50",
        "p90",
        "p99",
        "max",
        "min",
        "uplink p50",
        "uplink p99",
        "p99 all runs",
    ):
        t.add_column(col, justify="right")
    for c in res["realtime"]:
        e, u = c["error_ms"], c["uplink_ms"]
        t.add_row(
            str(c["n"]),
            str(c["k"]),
            fmt(c["samples"]),
            fmt(e.get("p50"), 2),
            fmt(e.get("p90"), 2),
            fmt(e.get("p99"), 2),
            fmt(e.get("max"), 2),
            fmt(e.get("min"), 2),
            fmt(u.get("p50"), 2),
            fmt(u.get("p99"), 2),
            " ".join(fmt(x, 1) for x in c["p99_all_runs_ms"]),
        )
    console.print(t)

    p = res["profile"]["k0"]
    t = Table(
        title=f"cProfile, N={p['n']} K=0, {p['ticks']} ticks: top functions by own time "
        f"({p['profiled_s']:.2f} s profiled, of which {p['gc_s_under_profile']:.2f} s in the garbage "
        "collector, charged to whichever function was running)"
    )
    for col in ("function", "calls", "own s", "share", "cum s"):
        t.add_column(col, justify="right" if col != "function" else "left")
    for r in p["top_tottime"][:12]:
        t.add_row(
            r["function"], fmt(r["calls"]), fmt(r["tottime_s"], 3), f"{100 * r['share']:.1f}%", fmt(r["cumtime_s"], 3)
        )
    console.print(t)
    t = Table(title="cProfile, N=1000 K=0: own time by component and cumulative time by stage")
    t.add_column("component")
    t.add_column("own s", justify="right")
    t.add_column("stage")
    t.add_column("cum s", justify="right")
    comps = list(p["components"].items())
    stages = list(p["stages"].items())
    for i in range(max(len(comps), len(stages))):
        a = comps[i] if i < len(comps) else ("", None)
        b = stages[i] if i < len(stages) else ("", None)
        t.add_row(a[0], fmt(a[1], 3), b[0], fmt(b[1], 3))
    console.print(t)
    k2 = res["profile"].get("k2")
    if k2:
        t = Table(
            title=f"cProfile, N={k2['n']} K=2, {k2['ticks']} ticks: who is busy during the ticks "
            f"(wall {k2['wall_s_under_profile']:.2f} s under profile)"
        )
        for col in ("process", "busy s", "busy share of wall", "largest stages (cum s)"):
            t.add_column(col)
        ws = k2["world"]["stages"]
        t.add_row(
            "world",
            fmt(k2["world_busy_s"], 2),
            pct(k2["world_busy_frac"]),
            ", ".join(
                f"{k.strip().split('.')[-1]} {v:.2f}" for k, v in ws.items() if k.startswith("  World") and v > 0
            ),
        )
        for i, h in enumerate(k2["hosts"]):
            hs = h["stages"]
            t.add_row(
                f"host {i}",
                fmt(k2["host_busy_s"][i], 2),
                pct(k2["host_busy_frac"][i]),
                f"step {hs['  RobotHost._step_lockstep']:.2f}, "
                f"unpack {hs['msgpack unpack, all callers (transport.codec.unpack)']:.2f}, "
                f"pack {hs['msgpack pack, all callers (transport.codec.pack)']:.2f}",
            )
        console.print(t)

    t = Table(title="Targets")
    for col in ("target", "measured", "met"):
        t.add_column(col)
    for row in res["targets"]:
        t.add_row(row["target"], row["measured"], "yes" if row["met"] else "NO")
    console.print(t)


def targets(res: dict) -> list[dict]:
    by = {(c["n"], c["k"]): c for c in res["lockstep"]}
    best = max(by[(1000, 0)]["robot_ticks_per_s"], by[(1000, 2)]["robot_ticks_per_s"])
    ratio = max(s["ratio_1000_vs_10"] for s in res["scaling"].values())
    p99 = res["realtime"][0]["error_ms"].get("p99", float("inf"))
    return [
        {
            "target": ">= 20,000 robot-ticks/s at N = 1000 (better of K = 0, 2; best run)",
            "measured": f"K=0 {by[(1000, 0)]['robot_ticks_per_s']:,.0f}, K=2 {by[(1000, 2)]['robot_ticks_per_s']:,.0f}",
            "met": best >= TARGETS["robot_ticks_per_s_n1000"],
        },
        {
            "target": "cost per robot-tick N=1000 / N=10 <= 1.5x",
            "measured": ", ".join(f"K={k}: {s['ratio_1000_vs_10']:.2f}x" for k, s in res["scaling"].items()),
            "met": ratio <= TARGETS["cost_ratio_n1000_vs_n10"],
        },
        {
            "target": "emulator deliveries/s >= raw Zenoh (best runs, default callback)",
            "measured": f"{res['deliveries']['ratio']:.2f}x raw",
            "met": res["deliveries"]["ratio"] >= 1.0,
        },
        {
            "target": "realtime p99 (latency - c) < 2 ms (N=100, K=0; best run)",
            "measured": f"{p99:.2f} ms",
            "met": p99 < TARGETS["realtime_p99_error_ms"],
        },
    ]


def markdown(res: dict) -> str:
    """Render the result tables as Markdown (for docs/benchmarks.md)."""
    m = res["machine"]
    out = [
        f"Machine: {m['nproc']} CPUs ({m['cpu_model']}), {m['platform']}, Python {m['python']}, "
        f"eclipse-zenoh {m['zenoh']}, msgpack {m['msgpack']}, numpy {m['numpy']}; swarmactors "
        f"{m['swarmactors']['package']} at commit {str(m['swarmactors']['commit'])[:10]}"
        + (f" with uncommitted changes in {len(m['worktree_changes'])} file(s)" if m.get("worktree_changes") else "")
        + f"; {res['config']['mode']} mode, {res['config']['repeats']} run(s) per case; load average "
        f"{m['loadavg_start'][0]:.2f} at the start, {m['loadavg_end'][0]:.2f} at the end; {m['date']}.",
        "",
        "### Lockstep throughput (beacon)",
        "",
        "| N | K | ticks | robot-ticks/s (best) | median | µs / robot-tick | deliveries/s | deliveries / robot-tick "
        "| world process CPU | GC share of tick loop (world process) |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for c in res["lockstep"]:
        out.append(
            f"| {c['n']} | {c['k']} | {c['ticks']} | {fmt(c['robot_ticks_per_s'])} | "
            f"{fmt(c['robot_ticks_per_s_median'])} | {fmt(c['us_per_robot_tick'], 1)} | "
            f"{fmt(c['deliveries_per_s'])} | {fmt(c['deliveries_per_robot_tick'], 2)} | "
            f"{pct(c['world_cpu_frac'])} | {pct(c['gc_share'])} |"
        )
    out += [
        "",
        "### Cost per robot-tick",
        "",
        "| K | µs / robot-tick, N = 10 | N = 100 | N = 1000 | ratio 1000 / 10 (best runs) | median runs |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for k, sc in res["scaling"].items():
        out.append(
            f"| {k} | {fmt(sc['us']['10'], 1)} | {fmt(sc['us']['100'], 1)} | {fmt(sc['us']['1000'], 1)} | "
            f"{sc['ratio_1000_vs_10']:.2f}x | {sc['ratio_1000_vs_10_median']:.2f}x |"
        )
    d = res["deliveries"]
    out += [
        "",
        "### Deliveries per second, emulator and raw Zenoh",
        "",
        "| deliveries per second | rate | runs |",
        "|---|---:|---|",
        f"| raw Zenoh pub/sub, 2 processes, default callback (`indirect=True`) | {fmt(d['raw']['msgs_per_s'])} | "
        + ", ".join(fmt(x) for x in d["raw"]["all_msgs_per_s"])
        + " |",
        f"| raw Zenoh pub/sub, callback on Zenoh's thread (`indirect=False`, as `transport.Link`) | "
        f"{fmt(d['raw_indirect_false']['msgs_per_s'])} | "
        + ", ".join(fmt(x) for x in d["raw_indirect_false"]["all_msgs_per_s"])
        + " |",
        f"| emulator, N = 1000, K = 2, lockstep beacon | {fmt(d['emulator_per_s'])} | best run |",
        f"| **ratio emulator / raw (default callback)** | **{d['ratio']:.2f}** | target >= 1 |",
        f"| ratio emulator / raw (`indirect=False`) | {d['ratio_vs_indirect_false']:.2f} | |",
    ]
    out += [
        "",
        f"### Realtime latency error (delivered latency − c), ms; c = 10 ms, dt = 50 ms, "
        f"{res['config']['realtime_s']:g} s per run; the run with the lowest p99",
        "",
        "| N | K | samples | p50 | p90 | p99 | max | min | uplink p50 | uplink p99 | p99 of every run |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for c in res["realtime"]:
        e, u = c["error_ms"], c["uplink_ms"]
        p99s = ", ".join(fmt(x, 1) for x in c["p99_all_runs_ms"])
        out.append(
            f"| {c['n']} | {c['k']} | {fmt(c['samples'])} | {fmt(e['p50'], 2)} | {fmt(e['p90'], 2)} | "
            f"{fmt(e['p99'], 2)} | {fmt(e['max'], 2)} | {fmt(e['min'], 2)} | {fmt(u['p50'], 2)} | "
            f"{fmt(u['p99'], 2)} | {p99s} |"
        )
    p = res["profile"]["k0"]
    out += [
        "",
        "### Profiles",
        "",
        f"cProfile of one N = {p['n']}, K = 0 run, {p['ticks']} ticks: {p['profiled_s']:.2f} s profiled "
        f"(wall {p['wall_s_under_profile']:.2f} s), of which {p['gc_s_under_profile']:.2f} s in the garbage "
        "collector (charged by cProfile to whichever function was running).",
        "",
        "| function | calls | own s | share | cumulative s |",
        "|---|---:|---:|---:|---:|",
    ]
    for r in p["top_tottime"][:12]:
        out.append(
            f"| `{r['function']}` | {fmt(r['calls'])} | {r['tottime_s']:.3f} | {100 * r['share']:.1f}% | "
            f"{r['cumtime_s']:.3f} |"
        )
    out += ["", "| stage (cumulative) | s |", "|---|---:|"]
    out += [
        f"| {k.strip()}{' (in the above)' if k.startswith('  ') else ''} | {v:.3f} |" for k, v in p["stages"].items()
    ]
    k2 = res["profile"].get("k2")
    if k2:
        out += [
            "",
            f"cProfile of one N = {k2['n']}, K = 2 run, {k2['ticks']} ticks (wall "
            f"{k2['wall_s_under_profile']:.2f} s under profile): time each process spends running its tick loop.",
            "",
            "| process | busy s | share of wall |",
            "|---|---:|---:|",
            f"| world | {k2['world_busy_s']:.2f} | {pct(k2['world_busy_frac'])} |",
        ]
        out += [
            f"| host {i} | {b:.2f} | {pct(f)} |"
            for i, (b, f) in enumerate(zip(k2["host_busy_s"], k2["host_busy_frac"], strict=True))
        ]
        ws = k2["world"]["stages"]
        out += [
            "",
            "World stages (cumulative s): "
            + ", ".join(f"{k.strip()} {v:.2f}" for k, v in ws.items() if k.startswith("  World")),
        ]
    out += ["", "### Targets", "", "| target | measured | met |", "|---|---|---|"]
    out += [f"| {t['target']} | {t['measured']} | {'yes' if t['met'] else '**no**'} |" for t in res["targets"]]
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer ticks, one repeat, no K=2 profile (under a minute)")
    ap.add_argument("--out", type=Path, default=HERE / "results.json", help="JSON results (default %(default)s)")
    ap.add_argument("--repeats", type=int, default=None, help="runs per case (best and median reported)")
    ap.add_argument(
        "--wait-quiet",
        type=float,
        default=0.0,
        metavar="SECONDS",
        help="first wait up to SECONDS for the 1-minute load average to fall below 0.5",
    )
    ap.add_argument(
        "--markdown",
        type=Path,
        metavar="RESULTS_JSON",
        help="print the tables of an existing results file as Markdown and exit (runs nothing)",
    )
    args = ap.parse_args(argv)
    if args.markdown:
        print(markdown(json.loads(args.markdown.read_text())), end="")
        return 0
    cfg = dict(QUICK if args.quick else FULL)
    if args.repeats:
        cfg["repeats"] = args.repeats
    if args.wait_quiet > 0:
        deadline = time.monotonic() + args.wait_quiet
        while os.getloadavg()[0] >= 0.5 and time.monotonic() < deadline:
            console.log(f"waiting for a quiet machine (load average {os.getloadavg()[0]:.2f})")
            time.sleep(15)
    t_start = time.perf_counter()
    res: dict = {"config": {"mode": "quick" if args.quick else "full", **cfg}, "targets_def": TARGETS}
    res["machine"] = machine()
    load = res["machine"]["loadavg_start"][0]
    if load > 0.5:
        console.log(
            f"[yellow]load average {load:.2f} before starting: other work on this machine "
            "will lower and scatter the numbers"
        )

    # Round-robin over the cases, repeat by repeat, so that a burst of load on
    # the machine spreads over every case instead of spoiling one.
    cases = [(n, k) for n in (10, 100, 1000) for k in (0, 2)]
    runs: dict[tuple, list] = {c: [] for c in cases}
    for rep in range(cfg["repeats"]):
        for n, k in cases:
            console.log(f"[{rep + 1}/{cfg['repeats']}] lockstep beacon N={n} K={k}, {cfg['ticks'][n]} ticks")
            run = lockstep_run(n, k, cfg["ticks"][n])
            for prob in run["problems"]:
                console.log(f"[red]N={n} K={k}: {prob}")
            runs[(n, k)].append(run)
    res["lockstep"] = [aggregate(n, k, cfg["ticks"][n], runs[(n, k)]) for n, k in cases]
    by = {(c["n"], c["k"]): c for c in res["lockstep"]}
    res["scaling"] = {
        str(k): {
            "us": {str(n): by[(n, k)]["us_per_robot_tick"] for n in (10, 100, 1000)},
            "ratio_1000_vs_10": by[(1000, k)]["us_per_robot_tick"] / by[(10, k)]["us_per_robot_tick"],
            "ratio_1000_vs_10_median": by[(1000, k)]["us_per_robot_tick_median"]
            / by[(10, k)]["us_per_robot_tick_median"],
        }
        for k in (0, 2)
    }

    payload = pack([1.0, b"\x00" * 8])  # == a beacon frame body in lockstep: [ctx.now, 8 zero bytes]
    raws: dict[bool, list] = {True: [], False: []}
    for rep in range(cfg["repeats"]):
        for indirect in (True, False):
            how = (
                "default callback (indirect=True)"
                if indirect
                else "callback on Zenoh's thread (indirect=False, as transport.Link)"
            )
            console.log(f"[{rep + 1}/{cfg['repeats']}] raw Zenoh pub/sub, {cfg['raw_s']} s, {how}")
            raws[indirect].append(raw_zenoh(cfg["raw_s"], payload, indirect=indirect))

    def best_raw(rs: list[dict]) -> dict:
        out = dict(max(rs, key=lambda r: r.get("msgs_per_s") or 0))
        out["all_msgs_per_s"] = [r.get("msgs_per_s") for r in rs]
        return out

    raw, raw_direct = best_raw(raws[True]), best_raw(raws[False])
    emu = by[(1000, 2)]["deliveries_per_s"]
    res["deliveries"] = {
        "raw": raw,
        "raw_indirect_false": raw_direct,
        "emulator_case": "N=1000 K=2 lockstep beacon",
        "emulator_per_s": emu,
        "beacon_body_bytes": beacon_body_size(),
        "ratio": emu / raw["msgs_per_s"] if raw.get("msgs_per_s") else float("nan"),
        "ratio_vs_indirect_false": emu / raw_direct["msgs_per_s"] if raw_direct.get("msgs_per_s") else float("nan"),
    }

    rt_runs: dict[int, list] = {0: [], 2: []}
    for rep in range(cfg["repeats"]):
        for k in rt_runs:
            console.log(f"[{rep + 1}/{cfg['repeats']}] realtime latency probe N=100 K={k}, {cfg['realtime_s']} s")
            rt_runs[k].append(realtime_case(100, k, cfg["realtime_s"]))

    def best_rt(rs: list[dict]) -> dict:
        ordered = sorted(rs, key=lambda r: r["error_ms"].get("p99", float("inf")))
        out = dict(ordered[0])
        out["p99_all_runs_ms"] = [r["error_ms"].get("p99") for r in rs]
        out["p99_median_ms"] = ordered[len(ordered) // 2]["error_ms"].get("p99")
        return out

    res["realtime"] = [best_rt(rt_runs[0]), best_rt(rt_runs[2])]

    console.log("profiling N=1000 K=0")
    res["profile"] = {"k0": profile_k0(1000, cfg["profile_ticks"])}
    if cfg["k2_profile"]:
        console.log("profiling N=1000 K=2 (world and hosts)")
        res["profile"]["k2"] = profile_k2(1000, cfg["profile_ticks"])

    res["targets"] = targets(res)
    res["machine"]["loadavg_end"] = list(os.getloadavg())
    res["bench_s"] = time.perf_counter() - t_start
    print_tables(res)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(res, indent=1, default=float, allow_nan=True) + "\n")
    console.log(f"wrote {args.out} ({res['bench_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Measuring for benchmarks/bench.py: every run of the emulator and of raw Zenoh, and the profiles.

Nothing here prints tables or decides what a number means: each function returns plain dicts (JSON-able)
that ``benchmarks/bench_report.py`` turns into tables and charts. The cases:

* ``lockstep_run``: one lockstep run of ``scenarios/beacon.toml`` (or of the do-nothing behaviour,
  ``idle_behavior:Idle``: the floor) at N robots and K host processes, through ``launcher.run_world``;
* ``raw_zenoh``: one publisher process and one subscriber process, one message per (frame, receiver);
* ``realtime_case``: the realtime latency probe (``latency_probe:LatencyProbe``);
* ``profile_k0`` / ``profile_k2``: cProfile of one N = 1000 run, in one process or per process.
"""

from __future__ import annotations

import asyncio
import cProfile
import gc
import json
import multiprocessing as mp
import os
import platform
import pstats
import queue
import subprocess
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
if str(HERE) not in sys.path:  # latency_probe, idle_behavior; spawned hosts inherit sys.path
    sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402
import zenoh  # noqa: E402

from swarmactors.oracle.result import package_version  # noqa: E402
from swarmactors.runs import launcher, scenario  # noqa: E402
from transport import Endpoints, make_config, pack  # noqa: E402

BEACON = ROOT / "scenarios" / "beacon.toml"
PROBE = "latency_probe:LatencyProbe"
IDLE = "idle_behavior:Idle"


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


def load_beacon(n: int, ticks: int, extra: list[str] = (), behavior: str = "beacon") -> dict:
    """scenarios/beacon.toml with N robots (trace off; the hash is still computed); ``behavior="idle"``: the floor."""
    if behavior == "idle":
        extra = [*extra, f'robots.0.behaviors=[{{use = "{IDLE}"}}]']
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


def lockstep_run(n: int, k: int, ticks: int, behavior: str = "beacon") -> dict:
    """One lockstep run (beacon, or ``idle``: robots that do nothing); rates over the tick loop only (``wall_s``)."""
    sc = load_beacon(n, ticks, behavior=behavior)
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


def aggregate(n: int, k: int, ticks: int, runs: list[dict], behavior: str = "beacon") -> dict:
    """One case over its repeats: the best run (least disturbed by other load) and the median."""
    ordered = sorted(runs, key=lambda r: r["robot_ticks_per_s"])
    med, best = ordered[len(runs) // 2], ordered[-1]
    return {
        "n": n,
        "k": k,
        "behavior": behavior,
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


def own_locator(session: zenoh.Session) -> str:
    """The first locator a peer session listens on (from its admin space), for another session to connect to."""
    locators = []
    for reply in session.get(f"@/{session.zid()}/peer", timeout=5.0):
        if reply.ok is not None:
            locators = json.loads(reply.ok.payload.to_bytes()).get("locators", [])
    return locators[0]


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
    ready.put(own_locator(session))
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
        print("raw Zenoh: no answer from the publisher or subscriber process", file=sys.stderr)
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
REALTIME_DT, REALTIME_C = 0.05, 0.01  # the realtime runs' tick and radio latency c


def realtime_scenario(n: int, seconds: float, behavior: str = PROBE, params: str = "") -> dict:
    """N beacon-placed robots running ``behavior`` in the realtime clock, dt = 50 ms, c = 10 ms, no trace.

    ``params``: the behaviour's parameters as TOML inline-table entries (e.g. ``"spread = 1.0"``).
    """
    return scenario.load(
        BEACON,
        overrides=[
            f"robots.0.count={n}",
            'run.clock="realtime"',
            f"run.dt={REALTIME_DT}",
            f"run.ticks={int(seconds / REALTIME_DT)}",
            f"radio.latency_s={REALTIME_C}",
            "run.trace=false",
            f'robots.0.behaviors=[{{use = "{behavior}"{", " + params if params else ""}}}]',
        ],
    )


def realtime_case(n: int, k: int, seconds: float) -> dict:
    dt, c = REALTIME_DT, REALTIME_C
    data, meters = run_emulator(realtime_scenario(n, seconds), k)
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
        ("/swarmactors/robot/", "swarmactors/robot/ (robot runtime and host session)"),
        ("/swarmactors/robot/behavior.py", "swarmactors/robot/behavior.py (context)"),
        ("/swarmactors/oracle/trace.py", "swarmactors/oracle/trace.py (trace hash)"),
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
            "LockstepClock.run": cum("world/clock.py", "run"),
            "  Simulation.begin": cum("world/sim.py", "begin"),
            "  WorldSession.exchange": cum("world/session.py", "exchange"),
            "  Simulation.deliver": cum("world/sim.py", "deliver"),
            "  Simulation.inputs": cum("world/sim.py", "inputs"),
            "  Simulation.take": cum("world/sim.py", "take"),
            "  Simulation.transmit": cum("world/sim.py", "transmit"),
            "  Simulation.end": cum("world/sim.py", "end"),
            "WorldSession._on_up_put": cum("world/session.py", "_on_up_put"),
            "HostSession._run_lockstep": cum("swarmactors/robot/session.py", "_run_lockstep"),
            "  RobotRuntime.step": cum("swarmactors/robot/runtime.py", "step"),
            "HostSession._on_down": cum("swarmactors/robot/session.py", "_on_down"),
            "message decode, all callers (transport.messages.decode)": cum("transport/messages.py", "decode"),
            "message encode, all callers (transport.messages.encode)": cum("transport/messages.py", "encode"),
        },
    }


def profile_k0(n: int, ticks: int, top: int = 15) -> dict:
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
    out = summarise_profile(pstats.Stats(prof), top=top)
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
    world_busy = world["stages"]["LockstepClock.run"] + world["stages"]["WorldSession._on_up_put"]
    host_busy = [h["stages"]["HostSession._run_lockstep"] + h["stages"]["HostSession._on_down"] for h in hosts]
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



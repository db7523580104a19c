"""Where a lockstep host's memory goes: a real world process and one host in this process under tracemalloc.

Usage: ``python benchmarks/host_memory.py [SECONDS]``. Starts ``swarmactors world`` (10 beacon robots, lockstep,
no trace) on a loopback port, runs the host here with ``tracemalloc`` on, and every SECONDS / 4 prints the
host's RSS, the Python-allocated total, the step count and the world process's RSS; at the end, the ten source
lines whose Python allocations grew most since the first sample. To measure another tree (the baseline of
docs/benchmarks.md), run the script with that tree first on ``PYTHONPATH``: the world process inherits it.
"""

from __future__ import annotations

import asyncio
import os
import socket
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

from swarmactors.robot.host import RobotHost
from transport import Endpoints, Keys, Link

SCENARIO = """
[run]
name = "hostmem"
seed = 1
ticks = 100000000
trace = false

[radio]
range = 1.0

[[robots]]
count = 10
placement = "grid"
spacing = 0.5
behaviors = [{ use = "beacon" }]
"""


def rss_mb(pid: int | str = "self") -> float:
    with open(f"/proc/{pid}/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def main(seconds: float) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    folder = Path(tempfile.mkdtemp())
    (folder / "s.toml").write_text(SCENARIO)
    world = subprocess.Popen([sys.executable, "-m", "swarmactors", "world", str(folder / "s.toml"), "--listen",
                              f"tcp/127.0.0.1:{port}", "--mode", "peer", "--run-id", "hm", "--quiet", "--no-plots",
                              "--out", str(folder / "out")], stderr=subprocess.DEVNULL,
                             cwd=folder)  # not this directory: the world imports swarmactors from PYTHONPATH
    try:
        time.sleep(3.0)
        asyncio.run(measure(port, seconds, world.pid))
    finally:
        world.kill()
        world.wait()


async def measure(port: int, seconds: float, world_pid: int) -> None:
    """Join the world at ``port`` and sample this host's memory for ``seconds`` after a warm-up."""
    with Link(Endpoints(mode="peer", connect=[f"tcp/127.0.0.1:{port}"])) as link:
        host = RobotHost(link, Keys("hm"))
        await host.join()
        task = asyncio.ensure_future(host.run())
        await asyncio.sleep(seconds / 4)  # warm-up
        tracemalloc.start(5)
        first, t0, tick0, rss0 = tracemalloc.take_snapshot(), time.perf_counter(), host.tick, rss_mb()
        world0 = rss_mb(world_pid)
        for _ in range(4):
            await asyncio.sleep(seconds / 4)
            py, _ = tracemalloc.get_traced_memory()
            steps = host.tick - tick0
            print(f"{time.perf_counter() - t0:6.0f} s  steps {steps:7d}  RSS +{rss_mb() - rss0:6.2f} MB "
                  f"({(rss_mb() - rss0) * 1e6 / max(steps, 1):5.0f} B/step)  python {py / 1e6:6.2f} MB  "
                  f"world RSS +{rss_mb(world_pid) - world0:6.2f} MB")
        last = tracemalloc.take_snapshot()
        for stat in last.compare_to(first, "lineno")[:10]:
            print(stat)
        task.cancel()


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 120.0)

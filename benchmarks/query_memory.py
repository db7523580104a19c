"""Memory growth per query of a bare zenoh-python get/queryable loop, as the lockstep step path uses it.

Usage: ``python benchmarks/query_memory.py [QUERIES [TIMEOUT_S]]``. Two sessions in one process (a queryable that
answers at once, a querier that sends ``QUERIES`` queries one after another with a callback handler, as
``transport.Link.query``); every ``QUERIES / 5`` queries it prints the resident set size (``/proc/self/statm``)
and what ``tracemalloc`` sees allocated by Python code, so that growth outside Python (in Zenoh's Rust
runtime) shows as RSS growth with a flat tracemalloc total. ``TIMEOUT_S`` is each query's timeout (the lockstep
step query used 24 h).
"""

from __future__ import annotations

import os
import sys
import threading
import time
import tracemalloc

import zenoh

PAGE = os.sysconf("SC_PAGE_SIZE")


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * PAGE / 1e6


def config(listen: list[str], connect: list[str]) -> zenoh.Config:
    cfg = zenoh.Config()
    cfg.insert_json5("mode", '"peer"')
    cfg.insert_json5("scouting/multicast/enabled", "false")
    cfg.insert_json5("listen/endpoints", str(listen).replace("'", '"'))
    cfg.insert_json5("connect/endpoints", str(connect).replace("'", '"'))
    return cfg


def main(n: int, timeout: float = 10.0) -> None:
    tracemalloc.start()
    port = 17000 + os.getpid() % 1000
    server = zenoh.open(config([f"tcp/127.0.0.1:{port}"], []))
    client = zenoh.open(config([], [f"tcp/127.0.0.1:{port}"]))
    payload = b"x" * 600

    def on_query(q: zenoh.Query) -> None:
        q.reply(str(q.key_expr), payload)
        q.drop()

    qable = server.declare_queryable("bench/up/h0", zenoh.handlers.Callback(on_query, indirect=False))
    time.sleep(1.0)
    done = threading.Event()
    got: list[bytes] = []

    def on_reply(reply: zenoh.Reply) -> None:
        if reply.ok is not None:
            got.append(reply.ok.payload.to_bytes())

    base_rss, (base_py, _) = rss_mb(), tracemalloc.get_traced_memory()
    t0 = time.perf_counter()
    for i in range(1, n + 1):
        done.clear()
        client.get("bench/up/h0", zenoh.handlers.Callback(on_reply, done.set, indirect=False), payload=payload,
                   timeout=timeout, target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE)
        done.wait(10.0)
        got.clear()
        if i % max(1, n // 5) == 0:
            py, _ = tracemalloc.get_traced_memory()
            print(f"{i:8d} queries  {time.perf_counter() - t0:6.1f} s  RSS +{rss_mb() - base_rss:7.2f} MB  "
                  f"python +{(py - base_py) / 1e6:6.2f} MB  ({(rss_mb() - base_rss) * 1e6 / i:6.0f} B/query RSS)")
    snap = tracemalloc.take_snapshot()
    for stat in snap.statistics("lineno")[:5]:
        print(stat)
    qable.undeclare()
    client.close()
    server.close()


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 50_000, float(sys.argv[2]) if len(sys.argv) > 2 else 10.0)

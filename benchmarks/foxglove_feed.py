"""What the live Foxglove feed costs a run: wall time with ``--foxglove`` and a subscribed client, and without.

Usage: ``python benchmarks/foxglove_feed.py SCENARIO [--rounds 3] [--set KEY=VALUE ...]``. Each round runs the
scenario twice, in turn (A/B interleaved, so load drifts hit both alike): plain, then with ``--foxglove 0`` and a
WebSocket client subscribed to every topic from the first moment it can be (it decodes nothing, counts the
messages). Prints each run's ``wall_s`` (result.json) and the ratio of the medians. Needs the [foxglove] extra.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import aiohttp

URL = re.compile(r"foxglove: (ws://\S+)")


async def _client(url: str, stop: threading.Event, counts: dict) -> None:
    async with aiohttp.ClientSession() as s, s.ws_connect(url, protocols=("foxglove.sdk.v1",)) as ws:
        subscribed = False
        while not stop.is_set():
            try:
                msg = await asyncio.wait_for(ws.receive(), 0.5)
            except asyncio.TimeoutError:
                continue
            if msg.type == aiohttp.WSMsgType.TEXT:
                doc = json.loads(msg.data)
                if doc["op"] == "advertise" and not subscribed:
                    subs = [{"id": i + 1, "channelId": c["id"]} for i, c in enumerate(doc["channels"])]
                    await ws.send_str(json.dumps({"op": "subscribe", "subscriptions": subs}))
                    subscribed = True
            elif msg.type == aiohttp.WSMsgType.BINARY:
                counts["messages"] = counts.get("messages", 0) + 1
            else:
                return


def one(scenario: str, sets: list[str], feed: bool, out: Path) -> tuple[float, int]:
    cmd = [sys.executable, "-m", "swarmactors", "run", scenario, "--quiet", "--no-plots", "--json", "--out", str(out)]
    cmd += [a for s in sets for a in ("--set", s)]
    if feed:
        cmd += ["--foxglove", "0"]
    log = out.with_suffix(".err")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=log.open("w"), text=True)
    stop, counts, thread = threading.Event(), {}, None
    if feed:
        while not URL.search(log.read_text()):
            if proc.poll() is not None:
                raise SystemExit(log.read_text())
            time.sleep(0.02)
        url = URL.search(log.read_text()).group(1)
        thread = threading.Thread(target=lambda: asyncio.run(_client(url, stop, counts)))
        thread.start()
    line = proc.stdout.readline()  # --json: printed when the run has ended (before the feed lingers)
    stop.set()
    if thread is not None:
        thread.join()
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=60)
    return json.loads(line)["wall_s"], counts.get("messages", 0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--set", action="append", default=[])
    args = ap.parse_args()
    walls: dict[bool, list[float]] = {False: [], True: []}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for feed in (False, True):
                wall, messages = one(args.scenario, args.set, feed, Path(tmp) / f"r{r}{'f' if feed else ''}")
                walls[feed].append(wall)
                print(f"round {r}: {'--foxglove + client' if feed else 'plain':20s} wall {wall:7.2f} s"
                      + (f"  ({messages} messages received)" if feed else ""), flush=True)
    a, b = statistics.median(walls[False]), statistics.median(walls[True])
    print(f"median plain {a:.2f} s, with the feed {b:.2f} s: ratio {b / a:.3f}")


if __name__ == "__main__":
    main()

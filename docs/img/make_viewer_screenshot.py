"""Make docs/img/viewer.png: the viewer on scenarios/stigmergy.toml, driven by Playwright and the system Chromium.

    python docs/img/make_viewer_screenshot.py [OUT.png]

Runs ``swarmactors run scenarios/stigmergy.toml --view``, plays it to tick 100 (roles elected), kills robot 12 by
clicking it on the way, inspects robot 3, and takes the screenshot.
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parents[2]


def main(out: Path) -> None:
    work = Path(tempfile.mkdtemp())
    log = work / "cli.log"
    proc = subprocess.Popen([sys.executable, "-m", "swarmactors", "run", str(ROOT / "scenarios/stigmergy.toml"),
                             "--out", str(work / "out"), "--view", "--view-port", "0", "--quiet"],
                            stderr=open(log, "w"))
    try:
        while not (m := re.search(r"viewer: (http://\S+/)", log.read_text())):
            assert proc.poll() is None, log.read_text()
            time.sleep(0.1)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path="/usr/bin/chromium", args=["--no-sandbox"])
            page = browser.new_page(viewport={"width": 1280, "height": 780})
            page.goto(m.group(1))
            page.wait_for_function("window.swarm && window.swarm.drawn.t === 0")
            page.select_option("#speed", "100")
            page.click("#play")
            page.wait_for_function("window.swarm.drawn.t >= 20", timeout=30_000)
            page.check("#tool-kill")
            page.mouse.click(*page.evaluate("window.swarm.screenOf(12)"))
            page.wait_for_function("window.swarm.frame.dead.length > 0", timeout=30_000)
            page.wait_for_function("window.swarm.drawn.t >= 100", timeout=30_000)
            page.click("#play")  # pause
            page.check("#tool-inspect")
            page.mouse.click(*page.evaluate("window.swarm.screenOf(3)"))
            page.wait_for_function("document.getElementById('robot').innerText.includes('frames sent')")
            time.sleep(0.5)
            page.screenshot(path=str(out))
            browser.close()
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)
        if proc.poll() is None:
            proc.kill()
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs/img/viewer.png")

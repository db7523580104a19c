"""Skip-or-fail for tests that need something a fresh machine may lack.

A test that needs Docker, root or network namespaces skips with the reason when
the thing is missing, unless an environment flag demands it (then it fails):
SWARMACTORS_REQUIRE_DOCKER=1, SWARMACTORS_REQUIRE_NETNS=1,
SWARMACTORS_REQUIRE_BROWSER=1. `.ci/run` sets the flags for what its machine has.
"""

from __future__ import annotations

import os
import shutil
import subprocess

import pytest


def _require(flag: str, ok: bool, reason: str) -> None:
    if ok:
        return
    if os.environ.get(flag) == "1":
        pytest.fail(f"{flag}=1 but {reason}")
    pytest.skip(reason)


def docker_available() -> bool:
    if not shutil.which("docker"):
        return False
    return subprocess.run(["docker", "info"], capture_output=True, timeout=30).returncode == 0


def compose_command() -> list[str] | None:
    """`docker compose` (v2 plugin) or `docker-compose` (v1), whichever works."""
    if shutil.which("docker") and subprocess.run(["docker", "compose", "version"], capture_output=True).returncode == 0:
        return ["docker", "compose"]
    if shutil.which("docker-compose"):
        return ["docker-compose"]
    return None


def require_docker() -> list[str]:
    _require("SWARMACTORS_REQUIRE_DOCKER", docker_available(), "no Docker engine answers `docker info`")
    compose = compose_command()
    _require("SWARMACTORS_REQUIRE_DOCKER", compose is not None, "neither `docker compose` nor `docker-compose` found")
    return compose


def require_netns() -> None:
    ok = os.geteuid() == 0 and shutil.which("ip") is not None
    if ok:
        ok = subprocess.run(["ip", "netns", "list"], capture_output=True).returncode == 0
    _require("SWARMACTORS_REQUIRE_NETNS", ok, "network namespaces need root and iproute2 (`ip netns`)")


BROWSERS = ("/usr/bin/chromium", "/usr/bin/chromium-browser")


def require_browser() -> str:
    """The system Chromium (Debian's `chromium` package) and Playwright to drive it; never a downloaded browser."""
    path = next((p for p in BROWSERS if os.access(p, os.X_OK)), None) or shutil.which("chromium")
    _require("SWARMACTORS_REQUIRE_BROWSER", path is not None, "no system Chromium (apt-get install chromium)")
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        _require("SWARMACTORS_REQUIRE_BROWSER", False, "Playwright is not installed (pip install '.[test]')")
    return path

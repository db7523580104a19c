"""The documentation site builds with ``mkdocs build --strict``.

A broken link or anchor, a page missing from the navigation or a navigation entry without its page fails the
build: mkdocs.yml's ``validation`` makes each a warning and ``--strict`` each warning a failure.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]  # the checkout's docs (CI installs a wheel, without them)

# The site's tools come with the test extra. .ci/run builds the site only through this module, so there
# (SWARMACTORS_REQUIRE_DOCS=1) a missing tool fails the run instead of skipping it.
for _tool in ("mkdocs", "material", "mkdocstrings_handlers.python"):
    if os.environ.get("SWARMACTORS_REQUIRE_DOCS") == "1":
        __import__(_tool)
    else:
        pytest.importorskip(_tool)


def _build(config: Path, site: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(config), "-d", str(site)],
                          capture_output=True, text=True, env=env, cwd=config.parent, timeout=300)


@pytest.fixture(scope="session")
def site(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """The checkout's site, built once per session: (its folder, the build)."""
    folder = tmp_path_factory.mktemp("docs") / "site"
    return folder, _build(ROOT / "mkdocs.yml", folder)


def test_the_site_builds_strictly(site):
    folder, out = site
    assert out.returncode == 0, out.stderr[-4000:]
    for page in ("index.html", "cli/index.html", "scenarios/index.html", "benchmarks/index.html",
                 "protocols/flooding/index.html", "changelog/index.html", "api/index.html"):
        assert (folder / page).is_file(), page
    assert "WARNING" not in out.stderr


def test_a_broken_link_fails_the_build(tmp_path):
    """The same configuration on a copy of the docs with one link to a page that does not exist."""
    docs = tmp_path / "docs"
    subprocess.run(["cp", "-r", str(ROOT / "docs"), str(docs)], check=True)
    for name in ("mkdocs.yml", "mkdocs_hooks.py", "README.md", "CHANGELOG.md"):
        (tmp_path / name).write_text((ROOT / name).read_text())
    page = docs / "trace.md"
    page.write_text(page.read_text() + "\nSee [the missing page](no-such-page.md).\n")
    out = _build(tmp_path / "mkdocs.yml", tmp_path / "site")
    assert out.returncode != 0
    assert "no-such-page.md" in out.stderr

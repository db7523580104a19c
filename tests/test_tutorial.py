"""The tutorial notebook executes (issue 26), so it cannot rot.

With nbclient and ipykernel installed the notebook runs in a real Jupyter kernel. Without them its code cells
run in order in one namespace registered as ``__main__``, compiled with top-level ``await`` and executed inside
a running asyncio loop, as a kernel runs them (which is what makes ``launcher.run``'s ``asyncio.run`` fail and
``notebook.arun`` necessary).
"""

from __future__ import annotations

import ast
import asyncio
import json
import sys
import types
from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parent.parent / "docs" / "tutorial.ipynb"


def _cells() -> list[str]:
    nb = json.loads(NOTEBOOK.read_text())
    return ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"]


@pytest.mark.slow
def test_tutorial_executes(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    try:
        import nbclient
        import nbformat
    except ImportError:
        nbclient = None
    if nbclient is not None:
        nb = nbformat.read(NOTEBOOK, as_version=4)
        nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                resources={"metadata": {"path": str(tmp_path)}}).execute()
    else:
        main = types.ModuleType("__main__")
        monkeypatch.setitem(sys.modules, "__main__", main)

        async def run_cells() -> None:
            for source in _cells():
                code = compile(source, "<tutorial cell>", "exec", flags=ast.PyCF_ALLOW_TOP_LEVEL_AWAIT)
                awaited = eval(code, main.__dict__)  # noqa: S307 - our own notebook
                if awaited is not None:
                    await awaited

        asyncio.run(run_cells())
    out = tmp_path / "out" / "tutorial"
    assert {p.name for p in out.glob("*.png")} == {"sweep.png", "swarm.png", "trajectories.png"}
    assert json.loads((out / "gossip" / "result.json").read_text())["checks"][0]["passed"]


def test_launcher_run_fails_in_a_running_loop_and_run_anywhere_does_not(tmp_path):
    """Why the notebook needs arun: asyncio.run inside a loop raises; run_anywhere uses a worker thread."""
    from swarmactors.notebook import run_anywhere

    async def inside() -> None:
        coro = asyncio.sleep(0)
        with pytest.raises(RuntimeError, match="running event loop"):
            asyncio.run(coro)
        coro.close()
        assert callable(run_anywhere)

    asyncio.run(inside())


@pytest.mark.slow
def test_run_anywhere_inside_a_loop(tmp_path):
    from swarmactors.notebook import run_anywhere

    sc = {"run": {"name": "anywhere", "ticks": 3}, "radio": {"range": 1.0},
          "robots": [{"count": 3, "behaviors": [{"use": "beacon"}]}]}

    async def inside():
        return run_anywhere(sc, out=tmp_path / "r")

    assert asyncio.run(inside())["ticks"] == 3

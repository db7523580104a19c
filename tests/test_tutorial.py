"""The tutorial notebook executes (issue 26), so it cannot rot.

The notebook runs in a real Jupyter kernel (nbclient + ipykernel, the test extra): its cells run inside the
kernel's asyncio loop, which is what makes ``launcher.run``'s ``asyncio.run`` fail and ``swarmactors.arun``
necessary, and its classes live in the kernel's ``__main__`` (hence K = 0). About 6 s, so not marked slow.
"""

from __future__ import annotations

import asyncio
import json
import time
from pathlib import Path

import nbclient
import nbformat
import pytest

NOTEBOOK = Path(__file__).resolve().parent.parent / "docs" / "tutorial.ipynb"


def test_tutorial_executes_in_a_kernel(tmp_path):
    nb = nbformat.read(NOTEBOOK, as_version=4)
    t0 = time.perf_counter()
    nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    elapsed = time.perf_counter() - t0
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors, errors
    out = tmp_path / "out" / "tutorial"
    assert {p.name for p in out.glob("*.png")} == {"sweep.png", "swarm.png", "trajectories.png"}
    assert json.loads((out / "gossip" / "result.json").read_text())["checks"][0]["passed"]
    printed = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs)
    assert "gossip.agreed passed" in printed and "pose rows" in printed
    print(f"tutorial executed in {elapsed:.1f} s")


def test_the_notebook_is_stored_with_its_outputs():
    """A reader who opens the notebook (on a code host, say) sees what every cell printed and drew."""
    nb = nbformat.read(NOTEBOOK, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    silent = [c.source[:60] for c in code if ("print(" in c.source or "display(" in c.source) and not c.outputs]
    assert not silent, silent
    outputs = [o for c in code for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert sum("image/png" in o.get("data", {}) for o in outputs) == 3  # the sweep, the swarm, the trajectories
    printed = "".join(o.get("text", "") for o in outputs)
    assert "gossip.agreed passed" in printed and "pose rows" in printed


def test_launcher_run_fails_in_a_running_loop_and_run_anywhere_does_not(tmp_path):
    """Why the notebook needs arun: asyncio.run inside a loop raises; run_anywhere uses a worker thread."""
    from swarmactors.tools.notebook import run_anywhere

    async def inside() -> None:
        coro = asyncio.sleep(0)
        with pytest.raises(RuntimeError, match="running event loop"):
            asyncio.run(coro)
        coro.close()
        assert callable(run_anywhere)

    asyncio.run(inside())


@pytest.mark.slow
def test_run_anywhere_inside_a_loop(tmp_path):
    from swarmactors.tools.notebook import run_anywhere

    sc = {"run": {"name": "anywhere", "ticks": 3}, "radio": {"range": 1.0},
          "robots": [{"count": 3, "behaviors": [{"use": "beacon"}]}]}

    async def inside():
        return run_anywhere(sc, out=tmp_path / "r")

    assert asyncio.run(inside())["ticks"] == 3

"""The Figs. 6-11 sweep's post step reads trials.csv back as ``main_job``'s rows (no run, no Zenoh).

The CSV has one column per key that any trial returned: a robot that exists only at larger N, or a message kind
that only some runs received, leaves empty cells in the other rows. Those must read as absent, never as 0 (a
missing robot would pull the per-robot processing time down) and never crash the aggregates.
"""

from __future__ import annotations

import csv

import pytest

from protocols.roles.experiments.paper import main_rows
from swarmactors.tools.sweep import _flatten, cell


def row(n: int, seed: int, cpu: float, kinds: dict, chain: bool = True) -> dict:
    """A row shaped as ``main_job`` returns it (only the keys the reader touches, plus a few scalars)."""
    return {"n": n, "seed": seed, "ticks": 2000, "targets": 3, "disconnections": 0 if chain else 53,
            "cpu_s": {i: cpu + i / 100 for i in range(n)}, "cpu_s_per_robot": cpu + (n - 1) / 200,
            "cpu_s_by_role": {"base_station": [cpu], "explorer": [cpu + 0.01] * (n - 1)},
            "received_per_tick": 3.0, "received_per_tick_by_kind": kinds,
            "checks": {"roles.leader": True, "roles.chain": chain, "roles.gabriel": True}}


def write_csv(path, values: list[dict]) -> None:
    """As the sweep writes a callable trial's dict: ``metric.`` cells, one column per key of any row."""
    rows = [{"error": "", **{f"metric.{k}": cell(v) for k, v in _flatten(value)}} for value in values]
    header = ["n", "trial", "seed", "error", *sorted({k for r in rows for k in r if k.startswith("metric.")})]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, header, restval="")
        w.writeheader()
        for k, r in enumerate(rows):
            w.writerow({"n": values[k]["n"], "trial": k, "seed": 7 * k, **r})


def test_empty_cells_read_as_absent_not_as_zero(tmp_path):
    small = row(3, 2000, 0.1, {"RS_STATE": 2.0})
    large = row(5, 2001, 0.2, {"RS_STATE": 3.0, "RS_HELP": 0.01}, chain=False)
    write_csv(tmp_path / "trials.csv", [small, large])
    text = (tmp_path / "trials.csv").read_text()
    assert ",," in text  # the small run's robots 3 and 4 and its RS_HELP are empty cells
    got = main_rows(tmp_path / "trials.csv")
    assert [r["cpu_s"] for r in got] == [small["cpu_s"], large["cpu_s"]]  # int robot ids, no None values
    assert got[0]["received_per_tick_by_kind"] == {"RS_STATE": 2.0}  # no RS_HELP key (the aggregate's 0)
    assert got[1]["received_per_tick_by_kind"] == {"RS_STATE": 3.0, "RS_HELP": 0.01}
    assert max(got[0]["cpu_s"].values()) == pytest.approx(0.12)  # the crash was max() over a None
    # the check names have dots: they must come back as the names, so that a failed check is seen
    assert got[1]["checks"] == {"roles.leader": True, "roles.chain": False, "roles.gabriel": True}
    assert got[0]["cpu_s_by_role"] == small["cpu_s_by_role"]


def test_the_saved_30_trial_rows_read_back_whole():
    """The sweep rows shipped with the docs: 150 rows, each robot of each run once, every check passed.

    (The rows before H6's child side had one chain break, N = 30, seed 2020; docs/protocols/roles.md.)
    """
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "protocols/roles/experiments/results/fig6-11_sweep.csv"
    rows = main_rows(path)  # from the checkout (the installed package has no results/)
    assert len(rows) == 150
    assert all(sorted(r["cpu_s"]) == list(range(r["n"])) for r in rows)
    failed = [(r["n"], r["seed"]) for r in rows if not all(r["checks"].values())]
    assert failed == []
    assert {r["n"]: len([s for s in rows if s["n"] == r["n"]]) for r in rows} == {n: 30 for n in (10, 20, 30, 40, 50)}

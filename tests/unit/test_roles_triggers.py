"""Algorithm 2's cost by trigger (issue 23) and the options circles = false / witnesses = "all"."""

import numpy as np

from protocols.roles.aat import Connections
from protocols.roles.params import RoleParams

X0 = np.zeros(2)
CROSS = {1: (1.0, 0.0), 2: (0.0, 1.0), 3: (-1.0, 0.0), 4: (0.0, -1.0)}  # four Gabriel neighbours of X0


def call(conn: Connections, robots: dict, role_changed: bool = False):
    ids = sorted(robots)
    return conn.refresh(X0, ids, np.array([robots[i] for i in ids], dtype=float), (), role_changed)


def test_tests_are_counted_by_trigger():
    conn = Connections("proposed", eta_c=3, d_c=10.0)
    call(conn, CROSS, role_changed=True)  # lines 4-5: 4 candidates x 3 other witnesses
    assert conn.links == {1, 2, 3, 4} and conn.by_trigger["role"] == 12 and conn.full_passed == 4
    call(conn, CROSS)  # |A_i| = 4 >= eta_c: only the circle tests of lines 9-15, nothing inside
    assert conn.by_trigger["circle"] == 12 and conn.by_trigger["circle_aat"] == 0
    inside = {**CROSS, 5: (0.5, 0.1)}  # robot 5 enters the circle of link 0-1
    added, removed, _ = call(conn, inside)
    assert conn.by_trigger["circle"] == 12 + 4 * 4  # 4 links x 4 other witnesses
    assert conn.by_trigger["circle_aat"] == 4 and added == [5] and removed == [1]
    assert conn.tests == sum(conn.by_trigger.values())
    call(conn, {2: CROSS[2], 5: (0.5, 0.1)})  # two robots left: |A_i| = 2 < eta_c, the full test
    assert conn.by_trigger["degree"] == 2 and conn.below_eta == 2  # this call and the first (no links yet)
    assert conn.report()["tests_by_trigger"] == conn.by_trigger


def test_without_circle_tests_links_are_kept_while_eta_c_holds():
    conn = Connections("proposed", eta_c=3, d_c=10.0, circles=False)
    call(conn, CROSS, role_changed=True)
    added, removed, _ = call(conn, {**CROSS, 5: (0.5, 0.1)})
    assert (added, removed) == ([], []) and conn.links == {1, 2, 3, 4}
    assert conn.by_trigger["circle"] == 0 and conn.tests == 12


def test_witness_and_circle_options_validate():
    assert RoleParams.problem({"leader": 1, "witnesses": "all", "circles": False}) is None
    assert "witnesses" in RoleParams.problem({"leader": 1, "witnesses": "some"})
    assert "circles" in RoleParams.problem({"leader": 1, "circles": 1})

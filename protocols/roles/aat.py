"""The acute angle test and Algorithm 2 (connection management), robot side: numpy only, no oracle.

Convention (shared with the oracle in ``oracle.py``, which uses the very same arithmetic): robot k *blocks*
the link i-j when the angle x_i x_k x_j is not acute, i.e. when

    (x_i - x_k) . (x_j - x_k) <= 0

which is "x_k inside or on the circle C_ij with diameter x_i x_j". A point exactly on the circle (a right
angle) blocks, as the paper asks for strictly acute angles. The test is symmetric in i and j and the products
are computed in the same order on both sides, so two robots with the same positions reach the same verdict,
bit for bit, and so does the oracle on the trace's positions.

Cost unit: one *angle test* is one evaluation of the dot product above for one (candidate, witness) pair. The
acute angle test of candidate j against the witness set R_k costs |R_k| - 1 tests (every sensed robot but j);
the circle test of Algorithm 2 lines 9-15 costs |A_i| x (|R_l| - 1). A link whose circle test failed is not
tested again (it cannot pass), the one departure from the letter of lines 9-25, with the same result.
Counted this way, the cost does not depend on the machine; the wall time of the same code is measured
beside it.
"""

from __future__ import annotations

import time

import numpy as np

PROPOSED, BASELINE = "proposed", "baseline"
MODES = (PROPOSED, BASELINE)


def blocked(xi: np.ndarray, cand: np.ndarray, wit: np.ndarray) -> np.ndarray:
    """(m, w) booleans: witness k blocks candidate j (angle x_i x_k x_j >= 90 degrees)."""
    ax = xi[0] - wit[:, 0]
    ay = xi[1] - wit[:, 1]
    bx = cand[:, 0][:, None] - wit[:, 0][None, :]
    by = cand[:, 1][:, None] - wit[:, 1][None, :]
    return (ax[None, :] * bx + ay[None, :] * by) <= 0.0


def within2(xi: np.ndarray, pos: np.ndarray, d: float) -> np.ndarray:
    """Booleans: squared distance from xi <= d**2 (the same formula as the oracle's)."""
    dx = pos[:, 0] - xi[0]
    dy = pos[:, 1] - xi[1]
    return dx * dx + dy * dy <= d * d


class Connections:
    """A_i restricted to the local leader / explorer links that Algorithm 2 governs.

    ``refresh`` runs one tick of Algorithm 2 (``proposed``) or of the baseline that tests every detectable
    robot every tick (``baseline``) and returns the links to add and to remove; the caller sends the
    CONNECT / DISCONNECT requests. Chain links (a local leader's parent) are not in ``links``; they count in
    |A_i| through ``fixed``.
    """

    __slots__ = ("mode", "eta_c", "d_c", "circles", "links", "tests", "baseline_tests", "runs", "wall", "calls",
                 "by_trigger", "runs_by_trigger", "below_eta", "degree_sum", "full_passed")

    def __init__(self, mode: str = PROPOSED, eta_c: int = 3, d_c: float = 1.0, circles: bool = True):
        self.mode, self.eta_c, self.d_c = mode, eta_c, d_c
        self.circles = circles  # False: skip lines 9-15 (links kept unless lines 4-7 trigger), for comparison
        # angle tests by what triggered them: "role" (lines 4-5, and a disconnected robot's every-tick test),
        # "degree" (lines 6-7, |A_i| < eta_c), "circle" (the circle tests of lines 9-15), "circle_aat" (lines
        # 17-25 on the robots the circles found), "repair" (a robot that believes it is linked to us)
        self.by_trigger = dict.fromkeys(("role", "degree", "circle", "circle_aat", "repair"), 0)
        self.runs_by_trigger = dict.fromkeys(("role", "degree", "circle", "repair"), 0)
        self.below_eta = 0  # calls with |A_i| (chain links included) < eta_c
        self.degree_sum = 0  # sum over calls of |A_i| before the call
        self.full_passed = 0  # robots passing a full test (lines 4-7): the Gabriel degree then
        self.links: set[int] = set()
        self.tests = 0  # angle tests done
        self.baseline_tests = 0  # angle tests the baseline would have done on the same inputs
        self.runs = 0  # ticks on which the acute angle test ran (R_AAT not empty)
        self.calls = 0
        self.wall = 0.0  # seconds spent in refresh

    def refresh(self, xi: np.ndarray, ids: list[int], pos: np.ndarray, unlinkable, role_changed: bool,
                force_all: bool = False, extra=(), fixed: int = 0) -> tuple[list[int], list[int], list[int]]:
        """Run one tick of Algorithm 2.

        ``ids``/``pos``: the sensed robots taking part (R_k, the witnesses);
        ``unlinkable``: ids that may witness but not be linked (a local leader's parent, chain links);
        ``extra``: robots to test anyway (a robot that believes it is linked to us).

        Returns (added, removed, rejected): links formed, links dropped, and ``extra`` robots that failed.
        """
        t0 = time.perf_counter()
        self.calls += 1
        w = len(ids)
        index = {rid: k for k, rid in enumerate(ids)}
        old = self.links
        # A link to a robot no longer sensed, beyond d_c, or known not to be linkable is gone.
        near = within2(xi, pos, self.d_c) if w else np.zeros(0, dtype=bool)
        keep = {j for j in old if j in index and near[index[j]] and j not in unlinkable}
        cand = [k for k in np.flatnonzero(near).tolist() if ids[k] not in unlinkable]  # R_l, as indices
        self.baseline_tests += len(cand) * max(w - 1, 0)
        known_fail: set[int] = set()  # links whose circle test just failed: their AAT cannot pass
        degree = len(keep) + fixed
        self.degree_sum += degree
        self.below_eta += degree < self.eta_c
        trigger = ("role" if role_changed or force_all or self.mode == BASELINE
                   else "degree" if degree < self.eta_c else "circle")
        if trigger != "circle":
            r_aat = set(cand)  # lines 4-7 (and the baseline: every detectable robot, every tick)
        else:  # lines 9-15: only links whose circle C_ij now holds another robot, and those robots
            r_aat = set()
            if keep and self.circles:
                lk = [index[j] for j in sorted(keep)]
                blk = blocked(xi, pos[lk], pos)
                blk[np.arange(len(lk)), lk] = False
                self.tests += len(lk) * (w - 1)
                self.by_trigger["circle"] += len(lk) * (w - 1)
                rows = np.flatnonzero(blk.any(axis=1)).tolist()
                if rows:
                    cand_set = set(cand)
                    for row in rows:
                        known_fail.add(lk[row])
                        r_aat.update(k for k in np.flatnonzero(blk[row]).tolist() if k in cand_set)
        extra_idx = {index[j] for j in extra if j in index and near[index[j]] and j not in unlinkable}
        found = set(r_aat)
        r_aat = (r_aat | extra_idx) - known_fail
        passed: set[int] = set()
        failed: set[int] = {ids[k] for k in known_fail}
        if r_aat:  # lines 17-25
            self.runs += 1
            order = sorted(r_aat)
            blk = blocked(xi, pos[order], pos)
            blk[np.arange(len(order)), order] = False
            self.tests += len(order) * (w - 1)
            n_repair = len(r_aat - found) if trigger == "circle" else 0  # tested only because of ``extra``
            key = "circle_aat" if trigger == "circle" else trigger
            self.by_trigger[key] += (len(order) - n_repair) * (w - 1)
            self.by_trigger["repair"] += n_repair * (w - 1)
            self.runs_by_trigger["circle" if trigger == "circle" and n_repair < len(order)
                                 else "repair" if trigger == "circle" else trigger] += 1
            ok = (~blk.any(axis=1)).tolist()
            for row, kj in enumerate(order):
                (passed if ok[row] else failed).add(ids[kj])
            if trigger != "circle":
                self.full_passed += len(passed)
        new = passed | (keep - failed)
        self.links = new
        self.wall += time.perf_counter() - t0
        rejected = sorted(ids[k] for k in extra_idx if ids[k] in failed)  # (extra robots are not links)
        rejected += sorted(j for j in extra if j not in index or not near[index[j]])
        return sorted(new - old), sorted(old - new), rejected

    def report(self) -> dict:
        return {"tests": self.tests, "baseline_tests": self.baseline_tests, "runs": self.runs,
                "calls": self.calls, "wall_s": round(self.wall, 6), "tests_by_trigger": dict(self.by_trigger),
                "runs_by_trigger": dict(self.runs_by_trigger), "below_eta": self.below_eta,
                "degree_sum": self.degree_sum, "full_passed": self.full_passed}

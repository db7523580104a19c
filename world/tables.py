"""A tick's tables and what hosts are handed from them: reach, sensing, poses, rays, known objects, inboxes.

``TickTables.compute`` builds, once per tick from the positions at the tick's start, the tables every rule of
the tick reads: who is in radio reach of whom (world/sensing.py; the one "who is in range"), what each robot
senses (globally or situated: world/situated.py), the links an obstacle hides, obstacle rays, each robot's
rounded pose and the objects it knows. ``inputs`` and ``deliveries`` cut a host's rows out of them as columns
(transport/messages.py: each frame body once per host).
"""

from __future__ import annotations

from collections import defaultdict
from typing import TYPE_CHECKING

import numpy as np

from transport.messages import F64, I32, Deliveries, FrameIn, Inputs
from world.registry import HostEntry
from world.sensing import Reach, Sensed, gather, reach, sense_arrays

if TYPE_CHECKING:
    from world.air import Copies
    from world.radio import Outgoing
    from world.sim import Simulation

POS_DIGITS = 6  # positions in traces, state and hashes are rounded to 1e-6 length units


class TickTables:
    """The tables of the current tick (``compute``), and the inputs and deliveries cut from them."""

    def __init__(self, sim: Simulation, known_by: dict[str, object]):
        self.sim = sim
        self.known_by = known_by  # object name -> "all", "sensing" or a list of robot ids
        dims = sim.dims
        self.reach: Reach = reach(np.zeros((0, dims)), np.zeros(0, dtype=np.int64), np.zeros(0))
        self.sensed = Sensed(np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, dims)))
        self.poses = np.zeros((0, dims + 1))  # each robot's pose row (position, heading), rounded
        self.known: dict[int, list[str]] | None = None  # objects each robot knows this tick (None: all)
        self.hidden: np.ndarray | None = None  # links of ``reach`` an obstacle blocks (None: none)
        self.rays: dict[int, list[float]] = {}  # robot -> obstacle range-ray distances
        self._host_codes_of: tuple | None = None  # host_codes: what its cache was built from
        self._host_codes: tuple[np.ndarray, list[str]] = (np.empty(0, dtype=np.int64), [])

    def compute(self) -> None:
        """Reach and sensing from this tick's positions; collisions recorded; poses, rays, known objects."""
        sim, r = self.sim, self.sim.robots
        alive = r.alive_ids()
        self.reach = reach(r.pos, alive, r.range)
        sensed_ids = self.reach if np.array_equal(r.sensing, r.range) else reach(r.pos, alive, r.sensing)
        self.sensed = sense_arrays(r.pos, sensed_ids, r.noise, sim.seed, sim.tick, POS_DIGITS)
        space = sim.space
        self.hidden = space.hidden_pairs(r.pos, self.reach) if space is not None else None
        self.rays = space.rays(r.pos, r.heading, r.sensing, r.rays, alive) if space is not None and r.rays.any() else {}
        if space is not None and r.body.any():
            for episode in space.collisions(sim.tick, r.pos, r):
                sim.record.event(sim.tick, episode)
        self.poses = np.round(np.hstack([r.pos, r.heading[:, None]]), POS_DIGITS)
        situated = sim.situated
        situated.sync(r.spec)
        if situated.active:  # situated sensing (world/situated.py): own frames, closest points
            rows = situated.sense(r.pos, r.heading, alive, r.sensing, r.noise, sensed_ids.as_dict(alive),
                                  self.sensed.as_dict(alive), sim.tick, POS_DIGITS)
            self.sensed = Sensed.from_dict(len(r.pos), sim.dims, rows)
            situated.own_poses(self.poses, r.pos, r.heading, POS_DIGITS)
        self.known = self._known_objects()

    def _known_objects(self) -> dict[int, list[str]] | None:
        """Which objects each robot knows (None: every robot knows every object, the default).

        An object's ``known_by`` is ``"all"`` (mission knowledge), ``"sensing"`` (robots whose sensing range
        reaches it this tick) or a list of robot ids.
        """
        if all(k == "all" for k in self.known_by.values()):
            return None
        sim, r = self.sim, self.sim.robots
        known: dict[int, list[str]] = defaultdict(list)
        alive = r.alive_ids()
        for name, who in self.known_by.items():
            if who == "all":
                ids = alive
            elif who == "sensing":
                d = np.linalg.norm(r.pos[alive] - np.array(sim.objects[name])[: sim.dims], axis=1)
                ids = alive[d <= r.sensing[alive]]
            else:
                ids = [i for i in who if i < len(r)]
            for rid in ids:
                known[int(rid)].append(name)
        return known

    def inputs(self, entry: HostEntry, due: Copies | None) -> Inputs:
        """One host's inputs for this tick, as columns (each frame body once per host).

        Its alive robots in id order; each one's pose, what it senses and its inbox (``due``: the tick's
        delivered copies, lockstep) are rows of this tick's tables, taken with a few array operations.
        """
        sim = self.sim
        ids = np.fromiter(entry.robots, dtype=np.int64, count=len(entry.robots))
        ids.sort()
        ids = ids[sim.robots.alive[ids]]
        sptr, sk = self.sensed.rows(ids)
        frames: list[FrameIn] = []
        inbox = refs = b""
        rab = None
        if due is not None and len(ids):
            iptr, dk = gather(np.searchsorted(due.dst, ids, "left"), np.searchsorted(due.dst, ids, "right"))
            if len(dk):
                used, local = np.unique(due.ref[dk], return_inverse=True)
                for k in used.tolist():
                    f, sent_tick = due.frames[k]
                    frames.append(FrameIn(f.src, f.kind, f.seq, f.body, sent_tick))
                inbox, refs = iptr.astype(I32).tobytes(), local.astype(I32).tobytes()
                if sim.situated.rab:
                    rab = self._rab_rows(ids, iptr, due.src[dk], due.seq[dk])
        known, rays = self.known, self.rays
        msg = Inputs(sim.tick, sim.now, sim.dims, ids.astype(I32).tobytes(), self.poses[ids].astype(F64).tobytes(),
                     sptr.astype(I32).tobytes() if len(sk) else b"", self.sensed.ids[sk].astype(I32).tobytes(),
                     self.sensed.at[sk].astype(F64).tobytes(), inbox, refs, frames,
                     None if known is None else [known.get(rid, []) for rid in ids.tolist()],
                     [rays.get(rid) for rid in ids.tolist()] if rays else None, rab, sim.objects)
        if entry.pending_dead:
            msg.dead, entry.pending_dead = entry.pending_dead, []
        if entry.pending_new:
            msg.new, entry.pending_new = entry.pending_new, []
        return msg

    def _rab_rows(self, ids: np.ndarray, iptr: np.ndarray, src: np.ndarray, seq: np.ndarray) -> list | None:
        """frame.rab: each robot's (range, bearing) of its inbox frames, flattened (None: it wants none, or none)."""
        situated = self.sim.situated
        rows: list[list[float] | None] = []
        src_l, seq_l, ptr = src.tolist(), seq.tolist(), iptr.tolist()
        for i, rid in enumerate(ids.tolist()):
            row: list[float] = []
            if situated.wants_rab(rid):
                for k in range(ptr[i], ptr[i + 1]):
                    row.extend(situated.take_rab(src_l[k], seq_l[k], rid))
            rows.append(row or None)
        return rows if any(r is not None for r in rows) else None

    def deliveries(self, frames: list[Outgoing], fr: np.ndarray, dst: np.ndarray, due: np.ndarray,
                   to_host: np.ndarray) -> dict[str, Deliveries]:
        """Realtime: per receiving live host, its copies as columns (each frame once per host).

        Copy i is frame ``frames[fr[i]]`` to ``dst[i]``, due at ``due[i]``; only those where ``to_host``.
        """
        sim = self.sim
        rab = sim.situated.rab
        codes, names = self.host_codes()
        of_host = codes[dst]
        out: dict[str, Deliveries] = {}
        for h, host in enumerate(names):
            if not sim.hosts[host].alive:
                continue
            sel = np.flatnonzero(to_host & (of_host == h))
            if not len(sel):
                continue
            used, refs = np.unique(fr[sel], return_inverse=True)
            table = [FrameIn(f.src, f.kind, f.seq, f.body, sim.now) for f in map(frames.__getitem__, used.tolist())]
            rows = None
            if rab:
                situated, mine = sim.situated, dst[sel].tolist()
                rows = [list(situated.take_rab(frames[k].src, frames[k].seq, d)) if situated.wants_rab(d) else None
                        for k, d in zip(fr[sel].tolist(), mine, strict=True)]
            out[host] = Deliveries.of(table, dst[sel], refs, due[sel], rows)
        return out

    def host_codes(self) -> tuple[np.ndarray, list[str]]:
        """Each robot's host as an index into the names returned (-1: none), for array selections per host.

        Rebuilt only when robots or hosts were added: a robot never changes host.
        """
        sim = self.sim
        key = (len(sim.robots.host), len(sim.hosts), sum(len(e.robots) for e in sim.hosts.values()))
        if self._host_codes_of != key:
            names = list(sim.hosts)
            codes = np.full(len(sim.robots.host), -1, dtype=np.int64)
            for h, name in enumerate(names):
                members = sim.hosts[name].robots
                codes[np.fromiter(members, dtype=np.int64, count=len(members))] = h
            self._host_codes_of, self._host_codes = key, (codes, names)
        return self._host_codes

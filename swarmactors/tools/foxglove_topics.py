"""The swarm as Foxglove topics: what an MCAP export and the live Foxglove feed publish (docs/foxglove.md).

One ``SwarmTopics`` turns the swarm as a viewer sees it (a ``Scene``: positions, status, failures, objects,
counters and the tick's frame rows) into messages ``(topic, log time in ns, payload bytes)``. The MCAP export
(``swarmactors.tools.mcap_export``) feeds it every tick record of a trace; the live feed
(``swarmactors.tools.foxglove_live``) feeds it the scene of a running world or of a replay at the pace it can
afford. Both publish the channels of ``CHANNELS``, with the well-known Foxglove schemas (foxglove.FrameTransforms,
PosesInFrame, SceneUpdate, Log), encoded by the ``foxglove-sdk`` package, and JSON messages for counters, status
and results.

Times come from the run's clock: tick t is at ``t * run.dt`` seconds (as nanoseconds since 0).
Needs the ``[foxglove]`` extra (``pip install 'swarmactors[foxglove]'``); robot hosts never import it.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from swarmactors.oracle.result import to_jsonable
from swarmactors.oracle.trace_tables import Headings, initial_headings
from swarmactors.tools.scene import Scene
from transport.messages import malformed_count
from world.linkrules import DROP_CAUSES

FOXGLOVE_MISSING = ("this needs the foxglove-sdk and mcap packages, which are not installed: "
                    "pip install 'swarmactors[foxglove]'")
WORLD_FRAME = "world"
MARKER = 0.1  # a robot without a body is drawn as a sphere of this fraction of its radio range in radius
FLAT_HEIGHT = 0.25  # height (length units) of obstacles and map walls in a 2-D world, and of ones without a top
PALETTE = ((0.12, 0.47, 0.71), (1.0, 0.5, 0.05), (0.17, 0.63, 0.17), (0.84, 0.15, 0.16), (0.58, 0.4, 0.74),
           (0.55, 0.34, 0.29), (0.89, 0.47, 0.76), (0.5, 0.5, 0.5), (0.74, 0.74, 0.13), (0.09, 0.75, 0.81))  # tab10
_LOG_TICK = re.compile(r"^\[(\d+)\]")  # a robot's log line starts with its tick: "[12] ..."
LOST = ("loss", "cut", "occluded", "bandwidth")  # drops of a receiver the frame reached: drawn as red lines


class FoxgloveMissing(ValueError):
    """The optional Foxglove packages are not installed (bad input, as a missing pyarrow for parquet: exit 2)."""


def sdk():
    """The ``foxglove`` package (foxglove-sdk), or ``FoxgloveMissing`` naming the extra to install."""
    try:
        import foxglove
        import foxglove.messages  # noqa: F401
    except ImportError as exc:
        raise FoxgloveMissing(FOXGLOVE_MISSING) from exc
    return foxglove


def _json_schema(title: str, description: str, properties: dict) -> dict:
    return {"title": title, "description": description, "type": "object", "properties": properties}


_COUNTS = {"type": "object", "additionalProperties": {"type": "integer"}}
_COUNTERS = {"sent": {"type": "integer"}, "delivered": {"type": "integer"}, "overheard": {"type": "integer"},
             "dropped": _COUNTS, "malformed": {"type": "integer"}}

# topic -> (Foxglove message class name, or a JSON schema; what it holds). docs/foxglove.md has the same table.
CHANNELS: dict[str, tuple[str | dict, str]] = {
    "/tf": ("FrameTransforms", "every tick: the pose of each alive robot as the frame robot/<id> in world"),
    "/robots/poses": ("PosesInFrame", "every tick: the poses of the alive robots in world, in id order"),
    "/robots/bodies": ("SceneUpdate", "when the alive robots or their colours change: a body per robot in its "
                                      "own frame (sphere, heading arrow, id), failed robots as red crosses"),
    "/world": ("SceneUpdate", "at the first tick and when an object moves: bounds, obstacles, map, objects"),
    "/radio/links": ("SceneUpdate", "every tick: a line between each pair of robots within each other's range"),
    "/radio/frames": ("SceneUpdate", "every tick: a line from sender to receiver per copy delivered (green), "
                                     "overheard (grey) or lost on the way (red: loss, cut, occluded, bandwidth)"),
    "/radio/counts": (_json_schema("swarmactors.RadioCounts", "frames of this tick and totals so far",
                                   {"tick": {"type": "integer"}, **_COUNTERS,
                                    "total": {"type": "object", "properties": _COUNTERS}}),
                      "every tick: frames sent, delivered, overheard, dropped by cause, malformed; and totals"),
    "/robots/status": (_json_schema("swarmactors.Status", "robots whose status fields changed, with all their "
                                                          "current fields",
                                    {"tick": {"type": "integer"},
                                     "robots": {"type": "array", "items": {"type": "object"}}}),
                       "each tick at which a status field changed: those robots' current status fields"),
    "/events": ("Log", "each event (kills, failures, crashes, cuts, partitions, moves, collisions) and each "
                       "malformed input, at its tick"),
    "/robots/log": ("Log", "the robots' log lines, at their ticks (from result.json: MCAP export only)"),
    "/run/result": (_json_schema("swarmactors.Result", "the end of the run: behaviour reports, counters, checks",
                                 {"tick": {"type": "integer"}, "robots": {"type": "array"},
                                  "world": {"type": "object"}, "metrics": {"type": "object"},
                                  "checks": {"type": "array"}}),
                    "at the last tick: each robot's behaviour reports and failure, the world's counters, metrics, "
                    "checks (from result.json: MCAP export only)"),
}


@dataclass(frozen=True)
class ChannelSpec:
    """A channel as both sinks register it: topic, message encoding and schema (name, encoding, bytes)."""

    topic: str
    encoding: str
    schema_name: str
    schema_encoding: str
    schema: bytes


def channel_specs() -> list[ChannelSpec]:
    """The channels of ``CHANNELS`` with their schemas (the Foxglove ones from foxglove-sdk)."""
    m = sdk().messages
    out = []
    for topic, (kind, _) in CHANNELS.items():
        if isinstance(kind, dict):
            out.append(ChannelSpec(topic, "json", kind["title"], "jsonschema", json.dumps(kind).encode()))
        else:
            schema = getattr(m, kind).get_schema()
            out.append(ChannelSpec(topic, "protobuf", schema.name, schema.encoding, bytes(schema.data)))
    return out


def tick_ns(t: int, dt: float) -> int:
    """The run's time of tick ``t`` in nanoseconds (``t * dt`` seconds)."""
    return max(0, round(t * dt * 1e9))


def yaw_quaternion(heading: float | None) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``heading`` about z (identity when unknown)."""
    if heading is None:
        return 0.0, 0.0, 0.0, 1.0
    return 0.0, 0.0, math.sin(heading / 2), math.cos(heading / 2)


def event_log(ev: dict) -> tuple[str, str, str]:
    """(level, name, text) of a trace event, for a foxglove.Log: failures are errors, collisions warnings."""
    source = f" ({ev['source']})" if ev.get("source") else ""
    if "failed" in ev:
        error = f": {ev['error']}" if ev.get("error") else ""
        level = "Error" if ev["failed"] == "crashed" else "Warning"
        return level, f"robot/{ev.get('robot')}", f"robot {ev.get('robot')} {ev['failed']}{error}{source}"
    if "host_lost" in ev:
        return "Error", "world", f"host {ev['host_lost']} lost ({ev.get('cause', '')})"
    if "collision" in ev:
        return ("Warning", "world", f"collision {ev['collision']} from tick {ev.get('start')} to {ev.get('end')}")
    if "added" in ev:
        return "Info", "world", f"robots {ev['added']} added{source}"
    rest = {k: v for k, v in ev.items() if k not in ("t", "source")}
    text = ", ".join(f"{k} {json.dumps(to_jsonable(v))}" for k, v in rest.items())
    return "Info", "world", f"{text}{source}"


class SwarmTopics:
    """Builds the messages of ``CHANNELS`` from a scene, remembering what it already published.

    ``update(scene, rec)`` gives every message due at the scene's tick: poses every call, bodies and the world
    when they changed, the status of robots whose fields changed (``rec["status"]`` when the tick record is
    known, else a comparison with what was last published), the events the scene gained since the last call,
    and the frames and counters of ``rec`` (the scene's tick record, None when the source has no frame rows).
    Headings follow ``export.Headings`` (the direction of each robot's last move between two updates), so an
    update per tick record gives the poses of ``swarmactors export``'s poses table.
    """

    def __init__(self, scenario: dict, dt: float | None = None, ranges: dict[int, float] | None = None):
        self.fg = sdk().messages
        self.scenario = scenario or {}
        self.dt = float(dt if dt is not None else (self.scenario.get("run") or {}).get("dt", 1.0))
        self.headings = Headings(initial_headings(self.scenario))
        self.ranges = dict(ranges or {})
        self.radius: dict[int, float] = {}  # body radii from the scenario's groups (robots in id order)
        rid = 0
        for g in self.scenario.get("robots", []):
            for _ in range(len(g.get("positions") or []) or int(g.get("count") or 0)):
                if g.get("body_radius"):
                    self.radius[rid] = float(g["body_radius"])
                rid += 1
        self.occluders = None  # obstacles that block links (radio.occlusion), by the occlusion oracle's shapes
        world = self.scenario.get("world") or {}
        if (self.scenario.get("radio") or {}).get("occlusion") and (world.get("obstacles") or world.get("map")):
            from swarmactors.oracle.occlusion_oracle import Occluders

            self.occluders = Occluders(world)
        self.colours: dict = {}  # value of the colouring field -> palette index, in order of first appearance
        self.status: dict[int, dict] = {}
        self._events: list | None = None  # the scene's list of events, and how many of them were published
        self.events_seen = 0
        self.bodies_key = None
        self.objects_key = None
        self.totals = {"sent": 0, "delivered": 0, "overheard": 0, "dropped": {}, "malformed": 0}

    # ------------------------------------------------------------ the one entry point
    def update(self, scene: Scene, rec: dict | None = None, every_tick: bool = False) -> list[tuple[str, int, bytes]]:
        """The messages due at ``scene.t``, encoded.

        ``rec`` is the scene's tick record when known (its frames, drawn on ``/radio/frames``, and its counters);
        ``every_tick``: this is called for every tick record in order (an export), so the status changes, the
        malformed inputs and the counters' totals are taken from the records, exactly; otherwise (a live feed
        that skips ticks) status changes are found by comparison and totals are the scene's.
        """
        if scene.t is None:
            return []
        t, ns = scene.t, tick_ns(scene.t, self.dt)
        headings = self.headings.feed({"pos": scene.pos})
        out: list[tuple[str, int, object]] = []
        if scene.events is not self._events:  # a new list (an export drops the events it published)
            self._events, self.events_seen = scene.events, 0
        for ev in scene.events[self.events_seen:]:
            when = ev.get("t") if isinstance(ev.get("t"), int) else t
            out.append(("/events", tick_ns(when, self.dt), self._log(when, *event_log(ev))))
        self.events_seen = len(scene.events)
        for reason in (rec or {}).get("mal", ()) if every_tick else ():
            out.append(("/events", ns, self._log(t, "Warning", "world", f"malformed input: {reason}")))
        objects_key = json.dumps(scene.objects, sort_keys=True)
        if objects_key != self.objects_key:
            self.objects_key = objects_key
            out.append(("/world", ns, self._world(scene)))
        transforms, poses = self._transforms_and_poses(t, scene.pos, headings)
        out.append(("/tf", ns, transforms))
        out.append(("/robots/poses", ns, poses))
        changed = self._status_changes(scene, rec if every_tick else None)
        if changed:
            out.append(("/robots/status", ns, {"tick": t, "robots": changed}))
        bodies = self._bodies_key(scene)
        if bodies != self.bodies_key:
            self.bodies_key = bodies
            out.append(("/robots/bodies", ns, self._bodies(t, scene)))
        points = self._robot_points(scene.pos)
        out.append(("/radio/links", ns, self._links(t, scene, points)))
        out.append(("/radio/frames", ns, self._frames(t, scene.pos, rec or {}, points)))
        out.append(("/radio/counts", ns, self._counts(t, rec, scene, every_tick)))
        return [(topic, when, encode(msg)) for topic, when, msg in out]

    def result(self, result: dict, t: int) -> list[tuple[str, int, bytes]]:
        """``/run/result`` and ``/robots/log`` from a run's result.json (its robots' reports and log lines)."""
        names = {b.get("as") or b.get("use") for g in self.scenario.get("robots", []) for b in g.get("behaviors", [])}
        robots, out = [], []
        for key, r in sorted(result.get("robots", {}).items(), key=lambda kv: int(kv[0])):
            rid = int(key)
            row = {"id": rid, "alive": r.get("alive"), "failed": r.get("failed"), "status": r.get("status")}
            row.update({name: r[name] for name in sorted(names) if name in r})
            robots.append(row)
            for line in r.get("log") or []:
                tick = _LOG_TICK.match(line)
                when = int(tick.group(1)) if tick else t
                out.append(("/robots/log", tick_ns(when, self.dt), encode(self._log(when, "Info", f"robot/{rid}",
                                                                                    line))))
        doc = {"tick": t, "robots": robots, "world": result.get("world", {}), "metrics": result.get("metrics", {}),
               "checks": result.get("checks", [])}
        out.append(("/run/result", tick_ns(t, self.dt), encode(to_jsonable(doc))))
        return out

    # ------------------------------------------------------------ builders
    def _stamp(self, t: int):
        sec, nsec = divmod(tick_ns(t, self.dt), 1_000_000_000)
        return self.fg.Timestamp(sec, nsec)

    def _pose(self, x: float, y: float, z: float = 0.0, heading: float | None = None):
        qx, qy, qz, qw = yaw_quaternion(heading)
        return self.fg.Pose(position=self.fg.Vector3(x=x, y=y, z=z),
                            orientation=self.fg.Quaternion(x=qx, y=qy, z=qz, w=qw))

    def _log(self, t: int, level: str, name: str, text: str):
        return self.fg.Log(timestamp=self._stamp(t), level=getattr(self.fg.LogLevel, level), message=text, name=name)

    def _transforms_and_poses(self, t: int, pos: list, headings: dict):
        """``/tf`` and ``/robots/poses`` of the same robots, sharing each robot's position and rotation."""
        fg, stamp = self.fg, self._stamp(t)
        vector, quaternion, transform, pose = fg.Vector3, fg.Quaternion, fg.FrameTransform, fg.Pose
        transforms, poses = [], []
        for row in pos:
            qx, qy, qz, qw = yaw_quaternion(headings.get(row[0]))
            v = vector(x=row[1], y=row[2], z=row[3] if len(row) > 3 else 0.0)
            q = quaternion(x=qx, y=qy, z=qz, w=qw)
            transforms.append(transform(timestamp=stamp, parent_frame_id=WORLD_FRAME, child_frame_id=f"robot/{row[0]}",
                                        translation=v, rotation=q))
            poses.append(pose(position=v, orientation=q))
        return (fg.FrameTransforms(transforms=transforms),
                fg.PosesInFrame(timestamp=stamp, frame_id=WORLD_FRAME, poses=poses))

    def _status_changes(self, scene: Scene, rec: dict | None) -> list[dict]:
        if rec is not None:
            ids = sorted(int(k) for k in rec.get("status", {}))
        else:
            ids = sorted(rid for rid, st in scene.status.items() if self.status.get(rid) != st)
        for rid in ids:
            self.status[rid] = dict(scene.status.get(rid, {}))
        return [{"id": rid, **to_jsonable(self.status[rid])} for rid in ids]

    def _colour_of(self, value) -> int | None:
        """A palette index per value of the colouring field (strings, booleans, integers; floats get none)."""
        if value is None or isinstance(value, float) or not isinstance(value, (str, bool, int)):
            return None
        key = (type(value), value)
        if key not in self.colours:
            self.colours[key] = len(self.colours)
        return self.colours[key] % len(PALETTE)

    def _bodies_key(self, scene: Scene) -> tuple:
        field = scene.field
        alive = tuple((row[0], self._colour_of(scene.status.get(row[0], {}).get(field)) if field else None)
                      for row in scene.pos)
        dead = tuple(sorted(rid for rid, d in scene.dead.items() if d.get("pos") is not None))
        return alive, dead

    def _range(self, scene: Scene, rid: int) -> float:
        return float(scene.ranges.get(rid, self.ranges.get(rid, scene.default_range)))

    def _bodies(self, t: int, scene: Scene):
        fg, stamp = self.fg, self._stamp(t)
        alive = {row[0] for row in scene.pos}
        entities = []
        for rid, colour in self.bodies_key[0]:
            r = self.radius.get(rid) or MARKER * self._range(scene, rid)
            rgb = PALETTE[colour] if colour is not None else (0.92, 0.92, 0.92)
            entities.append(fg.SceneEntity(
                timestamp=stamp, frame_id=f"robot/{rid}", id=f"robot/{rid}", frame_locked=True,
                metadata=[fg.KeyValuePair(key="id", value=str(rid))],
                spheres=[fg.SpherePrimitive(pose=self._pose(0.0, 0.0), size=fg.Vector3(x=2 * r, y=2 * r, z=2 * r),
                                            color=fg.Color(r=rgb[0], g=rgb[1], b=rgb[2], a=0.9))],
                arrows=[fg.ArrowPrimitive(pose=self._pose(0.0, 0.0), shaft_length=1.4 * r, shaft_diameter=0.25 * r,
                                          head_length=0.6 * r, head_diameter=0.6 * r,
                                          color=fg.Color(r=0.2, g=0.2, b=0.2, a=1.0))],
                texts=[fg.TextPrimitive(pose=self._pose(0.0, 0.0, 1.6 * r), billboard=True, font_size=12.0,
                                        scale_invariant=True, color=fg.Color(r=0.1, g=0.1, b=0.1, a=1.0),
                                        text=str(rid))]))
        for rid, d in sorted(scene.dead.items()):
            if rid in alive or d.get("pos") is None:
                continue
            p, r = d["pos"], self.radius.get(rid) or MARKER * self._range(scene, rid)
            z = p[2] if len(p) > 2 else 0.0
            cross = [(p[0] - r, p[1] - r, z), (p[0] + r, p[1] + r, z), (p[0] - r, p[1] + r, z), (p[0] + r, p[1] - r, z)]
            entities.append(fg.SceneEntity(
                timestamp=stamp, frame_id=WORLD_FRAME, id=f"failed/{rid}",
                metadata=[fg.KeyValuePair(key="failed", value=str(d.get("cause")))],
                lines=[self._lines(cross, (0.85, 0.1, 0.1, 1.0))]))
        return fg.SceneUpdate(deletions=[fg.SceneEntityDeletion(timestamp=stamp, type=fg.SceneEntityDeletionType.All)],
                              entities=entities)

    def _lines(self, points: Iterable[tuple], rgba: tuple, thickness: float = 2.0, indices: list[int] | None = None):
        """A line list: segments between consecutive pairs of ``points`` (tuples or Point3), or of ``indices``."""
        fg = self.fg
        return fg.LinePrimitive(type=fg.LinePrimitiveLineType.LineList, pose=self._pose(0.0, 0.0),
                                thickness=thickness, scale_invariant=True,
                                points=[p if isinstance(p, fg.Point3) else
                                        fg.Point3(x=p[0], y=p[1], z=p[2] if len(p) > 2 else 0.0) for p in points],
                                color=fg.Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]), indices=indices)

    def _robot_points(self, pos: list) -> list:
        """A Point3 per alive robot, in the order of ``pos``: the line lists index them."""
        point = self.fg.Point3
        return [point(x=row[1], y=row[2], z=row[3] if len(row) > 3 else 0.0) for row in pos]

    def _links(self, t: int, scene: Scene, points: list):
        """Pairs within each other's range and, with ``radio.occlusion``, not behind an obstacle.

        The radio graph of ``Result.graph_at`` without the cuts and partitions of events.
        """
        keep = []
        if len(scene.pos) > 1:
            xyz = np.array([[*row[1:3], row[3] if len(row) > 3 else 0.0] for row in scene.pos], dtype=float)
            rng = np.array([self._range(scene, row[0]) for row in scene.pos])
            pairs = cKDTree(xyz).query_pairs(float(rng.max()), output_type="ndarray")
            if len(pairs):
                d = np.linalg.norm(xyz[pairs[:, 0]] - xyz[pairs[:, 1]], axis=1)
                keep = pairs[(d <= rng[pairs[:, 0]]) & (d <= rng[pairs[:, 1]])]
                if self.occluders is not None:
                    keep = [pair for pair in keep if not self.occluders.blocks(xyz[pair[0]], xyz[pair[1]])]
                keep = np.asarray(keep, dtype=int).ravel().tolist()
        fg = self.fg
        return fg.SceneUpdate(entities=[fg.SceneEntity(
            timestamp=self._stamp(t), frame_id=WORLD_FRAME, id="links",
            lines=[self._lines(points, (0.55, 0.55, 0.55, 0.6), 1.0, keep)] if keep else [])])

    def _frames(self, t: int, pos: list, rec: dict, points: list):
        at = {row[0]: i for i, row in enumerate(pos)}

        def segments(rows, lost: bool) -> list[int]:
            out = []
            for row in rows:
                a, b = at.get(row[0]), at.get(row[2])
                if a is not None and b is not None and (not lost or row[3] in LOST):
                    out += [a, b]
            return out

        lines = []
        for rows, rgba, lost in ((rec.get("del", ()), (0.1, 0.7, 0.2, 0.9), False),
                                 (rec.get("ovh", ()), (0.6, 0.6, 0.6, 0.7), False),
                                 (rec.get("drop", ()), (0.85, 0.1, 0.1, 0.9), True)):
            indices = segments(rows, lost)
            if indices:
                lines.append(self._lines(points, rgba, 2.0, indices))
        fg = self.fg
        return fg.SceneUpdate(entities=[fg.SceneEntity(timestamp=self._stamp(t), frame_id=WORLD_FRAME, id="frames",
                                                       lines=lines)])

    def _counts(self, t: int, rec: dict | None, scene: Scene, every_tick: bool) -> dict:
        """This tick's frame counters and the totals so far.

        The tick's are None without its record (a summary trace's ``ndel``/``novh``/``ndrop`` count too); the
        totals are summed over every record, or the scene's counters for a feed that skips ticks.
        """
        now = None
        if rec is not None:
            dropped: dict[str, int] = {}
            for row in rec.get("drop", ()):
                dropped[row[3]] = dropped.get(row[3], 0) + 1
            for cause, n in (rec.get("ndrop") or {}).items():
                dropped[cause] = dropped.get(cause, 0) + n
            now = {"sent": len(rec.get("sent", ())), "delivered": len(rec.get("del", ())) + rec.get("ndel", 0),
                   "overheard": len(rec.get("ovh", ())) + rec.get("novh", 0), "dropped": dict(sorted(dropped.items())),
                   "malformed": malformed_count(rec.get("mal", []))}
        tot = self.totals
        if every_tick and now is not None:
            for k in ("sent", "delivered", "overheard", "malformed"):
                tot[k] += now[k]
            for cause, n in now["dropped"].items():
                tot["dropped"][cause] = tot["dropped"].get(cause, 0) + n
        elif not every_tick:
            tot.update(sent=scene.sent, delivered=scene.deliveries if scene.frames_available else None,
                       overheard=scene.overheard if scene.frames_available else None,
                       malformed=scene.dropped.get("malformed", 0),
                       dropped={c: n for c, n in scene.dropped.items() if c != "malformed"})
        total = {**tot, "dropped": {c: tot["dropped"].get(c, 0) for c in DROP_CAUSES if c != "malformed"}}
        return {"tick": t, **(now or dict.fromkeys(("sent", "delivered", "overheard", "dropped", "malformed"))),
                "total": total}

    def _world(self, scene: Scene):
        """Bounds (a grey outline), obstacles and map walls (prisms), water, and named objects (orange cubes)."""
        fg, stamp = self.fg, self._stamp(scene.t or 0)
        world = self.scenario.get("world") or {}
        bounds = world.get("bounds")
        lo_z, hi_z = 0.0, FLAT_HEIGHT
        if bounds and len(bounds[0]) > 2:
            lo_z, hi_z = float(bounds[0][2]), float(bounds[1][2])
        entities = []
        if bounds:
            (x0, y0), (x1, y1) = bounds[0][:2], bounds[1][:2]
            entities.append(fg.SceneEntity(timestamp=stamp, frame_id=WORLD_FRAME, id="bounds", lines=[
                self._lines([(x0, y0), (x1, y0), (x1, y0), (x1, y1), (x1, y1), (x0, y1), (x0, y1), (x0, y0)],
                            (0.5, 0.5, 0.5, 1.0), 1.0)]))
        triangles = []
        for ob in world.get("obstacles") or []:
            z = ob.get("z") or [None, None]
            triangles += _prism(ob["xy"], lo_z if z[0] is None else z[0], hi_z if z[1] is None else z[1])
        cubes = self._map_cubes(world.get("map"), lo_z, hi_z)
        if triangles or cubes:
            grey = fg.Color(r=0.35, g=0.35, b=0.38, a=0.85)
            entities.append(fg.SceneEntity(
                timestamp=stamp, frame_id=WORLD_FRAME, id="obstacles", cubes=cubes,
                triangles=[fg.TriangleListPrimitive(pose=self._pose(0.0, 0.0), color=grey,
                                                    points=[fg.Point3(x=p[0], y=p[1], z=p[2]) for p in triangles])]
                if triangles else []))
        if scene.objects:
            size = fg.Vector3(x=0.3, y=0.3, z=0.3)
            entities.append(fg.SceneEntity(
                timestamp=stamp, frame_id=WORLD_FRAME, id="objects",
                cubes=[fg.CubePrimitive(pose=self._pose(*_xyz(p)), size=size,
                                        color=fg.Color(r=0.95, g=0.64, b=0.25, a=1.0)) for p in scene.objects.values()],
                texts=[fg.TextPrimitive(pose=self._pose(*_xyz(p, 0.4)), billboard=True, font_size=12.0,
                                        scale_invariant=True, color=fg.Color(r=0.6, g=0.3, b=0.0, a=1.0), text=name)
                       for name, p in scene.objects.items()]))
        return fg.SceneUpdate(deletions=[fg.SceneEntityDeletion(timestamp=stamp, type=fg.SceneEntityDeletionType.All)],
                              entities=entities)

    def _map_cubes(self, m: dict | None, lo_z: float, hi_z: float) -> list:
        """One cube per blocked cell of each layer (``@``), one flat blue tile per water cell (``W``)."""
        if not m:
            return []
        fg, cell = self.fg, float(m["cell"])
        x0, y0 = m["origin"]
        h = len(m["layers"][0]["rows"])
        out = []

        def cube(r: int, c: int, z0: float, z1: float, rgba: tuple):
            centre = (x0 + (c + 0.5) * cell, y0 + (h - r - 0.5) * cell, (z0 + z1) / 2)
            return fg.CubePrimitive(pose=self._pose(*centre), size=fg.Vector3(x=cell, y=cell, z=max(z1 - z0, 1e-3)),
                                    color=fg.Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]))

        for layer in m["layers"]:
            z = layer.get("z") or [None, None]
            z0, z1 = lo_z if z[0] is None else z[0], hi_z if z[1] is None else z[1]
            for r, row in enumerate(layer["rows"]):
                out += [cube(r, c, z0, z1, (0.3, 0.3, 0.33, 0.9)) for c, ch in enumerate(row) if ch == "@"]
        for r, row in enumerate(m.get("water") or []):
            out += [cube(r, c, lo_z, lo_z + 0.01, (0.3, 0.5, 0.9, 0.5)) for c, ch in enumerate(row) if ch == "W"]
        return out


def _xyz(p: list, dz: float = 0.0) -> tuple[float, float, float]:
    return float(p[0]), float(p[1]), (float(p[2]) if len(p) > 2 else 0.0) + dz


def _prism(xy: list, z0: float, z1: float) -> list[tuple[float, float, float]]:
    """Triangles (three points each) of a convex polygon extruded from z0 to z1: top, bottom and sides."""
    pts = []
    n = len(xy)
    for i in range(1, n - 1):  # a fan over the convex polygon
        for z in (z0, z1):
            pts += [(xy[0][0], xy[0][1], z), (xy[i][0], xy[i][1], z), (xy[i + 1][0], xy[i + 1][1], z)]
    for i in range(n):
        (ax, ay), (bx, by) = xy[i][:2], xy[(i + 1) % n][:2]
        pts += [(ax, ay, z0), (bx, by, z0), (bx, by, z1), (ax, ay, z0), (bx, by, z1), (ax, ay, z1)]
    return pts


def encode(msg) -> bytes:
    """A message's payload: a JSON document as UTF-8, a Foxglove message in protobuf (foxglove-sdk's encoder)."""
    if isinstance(msg, dict):
        return json.dumps(msg, separators=(",", ":")).encode()
    return msg.encode()

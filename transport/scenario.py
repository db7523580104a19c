"""The scenario model: every key of a scenario, with its type, default, limits and the rules between keys, once.

A scenario (docs/scenarios.md) is ``Scenario{run, radio, world, robots[], events[], checks[]}``. Each section is a
msgspec ``Struct`` whose fields carry their type, default, limits and meaning: the JSON Schema that
``swarmactors schema`` prints and the key tables of docs/scenarios.md are generated from them. The same types hold
the *resolved* scenario the world runs and result.json stores (``swarmactors.runs.scenario`` places the robots, reads
the map and checks the behaviours; ``Scenario.to_dict`` is its JSON form).

The model sits below the runner and the world, which both import it; it imports nothing above ``transport``.
``decode`` turns data (a parsed TOML table, a control command's arguments) into a typed spec, or raises
``SpecError`` naming the key path (``robots[0].range``) and the rule broken, with the value. The rules between keys
are the ``check`` methods and functions below. One robot spec (``RobotSpec``) serves a group's robots, a scenario's
``add`` event and the control ``add`` command, under the same limits (``robot_spec``). The world's actions (events
and control commands) are defined here too (``ACTIONS``, ``action_problem``); transport/messages.py re-exports them.
"""

from __future__ import annotations

import difflib
import functools
import math
import re
import sys
from typing import Annotated, Any, ClassVar, Literal

import msgspec
import numpy as np
from msgspec import UNSET, Meta, UnsetType

# ----------------------------------------------------------------- limits
INT64 = 1 << 63
FLOAT_MAX = sys.float_info.max  # a number within +-FLOAT_MAX is finite: the bound every number key has at least
MAX_COORD = 1e9  # length units: the largest |coordinate| (and length: range, sensing, body radius) a robot may have
MAX_SPEED = 1e6  # length units per second: the largest speed cap, and the largest velocity command the world takes
MAX_RADIO_RULES = 32  # [[radio.rules]] tables a scenario may add
MAX_DRIFT_PPM = 1e5  # the largest |clock_drift| (10 %)
MAX_CLOCK_OFFSET_S = 1e6  # the largest |clock_offset|, seconds (11.6 days)
MAX_OBSTACLE_RAYS = 1024  # range rays per robot (ctx.rays): a lidar's beams, not more
MAX_PER_REQUEST = 1000  # robots one ``add`` (event or command) or one mid-run join may create
MAX_ROBOTS = 10_000  # the default of world.max_robots
MAX_ROBOTS_LIMIT = 1_000_000  # the largest world.max_robots (robot ids fit the wire's int32 columns)
FULL_TURN = (-math.pi, math.pi)  # the heading offset drawn under local sensing when the group gives none
NAME = r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$"  # a run name is a directory name: no separators, no parent


class SpecError(ValueError):
    """Data that breaks the model: ``key`` is the path of the offending key (``robots[0].range``)."""

    def __init__(self, key: str, problem: str):
        super().__init__(f"{key}: {problem}" if key else problem)
        self.key, self.problem = key, problem


# ----------------------------------------------------------------- value types
def number(*, gt: float | None = None, ge: float | None = None, le: float = FLOAT_MAX) -> Any:
    """A number (an integer or a float, kept as given; never a boolean) within limits, always finite."""
    if gt is None and ge is None:
        ge = -FLOAT_MAX
    as_float = Annotated[float, Meta(gt=gt, ge=ge, le=le)]
    whole = {k: (math.ceil(v) if k == "ge" else math.floor(v) if k == "le" else int(v))
             for k, v in (("gt", gt), ("ge", ge), ("le", le)) if v is not None and abs(v) < INT64}
    return Annotated[int, Meta(**whole)] | as_float


Number = number()
Positive = number(gt=0)
Length = number(gt=0, le=MAX_COORD)  # a distance: > 0, at most MAX_COORD
Size = number(ge=0, le=MAX_COORD)  # a distance or spread that may be 0
Coord = number(ge=-MAX_COORD, le=MAX_COORD)
Speed = number(gt=0, le=MAX_SPEED)
Probability = number(ge=0, le=1)
RobotId = Annotated[int, Meta(ge=0, le=INT64 - 1)]
Tick = Annotated[int, Meta(ge=0)]
Point = Annotated[list[Coord], Meta(min_length=2, max_length=3)]  # [x, y] or [x, y, z]
XY = Annotated[list[Coord], Meta(min_length=2, max_length=2)]
Corners = Annotated[list[Point], Meta(min_length=2, max_length=2)]  # [[min...], [max...]]
Interval = Annotated[list[Number], Meta(min_length=2, max_length=2)]  # [lo, hi]
Pair = Annotated[list[RobotId], Meta(min_length=2, max_length=2)]
BehaviorSpec = Annotated[dict[str, Any], Meta(extra_json_schema={
    "required": ["use"], "properties": {
        "use": {"type": "string", "minLength": 1, "description": "a registered behaviour's name or module:Class"},
        "as": {"type": "string", "minLength": 1, "description": "the name its report goes under"}}})]
CheckSpec = Annotated[dict[str, Any], Meta(extra_json_schema={
    "required": ["use"], "properties": {
        "use": {"type": "string", "minLength": 1, "description": "a registered check's name or module:function"}}})]


def key(typ: Any, meaning: str, default: str | None = None, shape: str | None = None, rule: str | None = None):
    """A key's type with its meaning (docs and JSON Schema).

    ``default`` and ``shape`` word the docs' cells where the type alone cannot; ``rule`` words the error when a
    value breaks the type's limits.
    """
    extra = {k: v for k, v in (("default", default), ("shape", shape), ("rule", rule)) if v is not None}
    return Annotated[typ, Meta(description=meaning, extra=extra or None)]


class _Spec(msgspec.Struct, kw_only=True, forbid_unknown_fields=True):
    """Base of the scenario's tables: unknown keys are errors (``unknown`` names what a key of it is)."""

    unknown: ClassVar[str] = "key"


# ----------------------------------------------------------------- [run]
class Run(_Spec):
    """``[run]``: the run's name, seed, clock and length, and what it records."""

    name: key(Annotated[str, Meta(pattern=NAME)],
              "name of the run: output directories `out/<name>/<UTC time>-s<seed>` (and `out/<name>/latest`), stem "
              "of the run id, plot title; 1 to 64 letters, digits, `.`, `_` or `-`",
              rule="must be 1 to 64 letters, digits, '.', '_' or '-', starting with a letter or digit "
                   "(it names a directory)") = "run"
    seed: key(Annotated[int, Meta(ge=0)], "seed of placement, radio loss and latency, sensing noise, `kill_fraction`, "
              "and every robot's `ctx.rng`") = 0
    clock: key(Literal["lockstep", "realtime"], "see [architecture.md](architecture.md#lockstep-clock)") = "lockstep"
    ticks: key(Annotated[int, Meta(gt=0)] | None, "number of ticks to run; required unless `duration` is given") = None
    duration: key(Positive | None, "run length in seconds, used only when `ticks` is absent: "
                  "`ticks = max(1, round(duration / dt))`") = None
    dt: key(Positive, "seconds per tick: motion advances `v·dt` per tick, and in realtime a tick lasts `dt` seconds "
            "of wall time; behaviours read it as `ctx.dt` (with `clock` as `ctx.clock`)") = 1.0
    watchdog_s: key(Positive, "wall-clock seconds a robot's step may take before the robot fails as `watchdog`; the "
                    "world declares a silent host lost after 2·`watchdog_s` + 5 s, which is also the Zenoh session "
                    "lease of the world and its host processes") = 10.0
    join_timeout_s: key(Positive, "how long the world waits for hosts to claim every robot before the run fails "
                        "([result.md](result.md#exit-codes))") = 60.0
    state_every: key(Annotated[int, Meta(ge=0)], "publish a `state` snapshot every this many ticks; 0 = never") = 1
    trace: key(bool | Literal["off", "summary", "full"],
               "what `trace.msgpack` holds: everything (`\"full\"`, `true`), no per-delivery rows (`\"summary\"`) or "
               "no file (`\"off\"`, `false`) ([trace.md](trace.md#trace-modes)); the trace hash is the same in every "
               "mode, but the flooding checks need the full trace") = True
    trace_compression: key(Literal["none", "zstd"], "write the trace through a Zstandard compressor (same name, same "
                           "records and hash; every reader of the project detects it; docs/trace.md)") = "none"
    processes: key(Annotated[int, Meta(ge=0)], "robot host processes K that the launcher spawns (`--processes K` "
                   "sets it); 0 runs the robots inside the world's process") = 0
    trace_commands: key(bool, "each tick record carries `cmd`, the velocities robots commanded at that tick before "
                        "the world's speed cap ([trace.md](trace.md))") = False

    def check(self) -> None:
        """``ticks`` from ``duration`` when absent: max(1, round(duration / dt)); one of them is required."""
        if self.ticks is None:
            if self.duration is None:
                raise SpecError("run.ticks", "give run.ticks (or run.duration in seconds)")
            self.ticks = max(1, int(round(self.duration / self.dt)))

    @property
    def trace_mode(self) -> str:
        """``trace`` as a trace mode: true is ``full``, false is ``off`` (swarmactors/oracle/trace.py)."""
        return ("full" if self.trace else "off") if isinstance(self.trace, bool) else self.trace


# ----------------------------------------------------------------- [radio.channel]
# The values a channel key takes when the table does not give it: generic (a 2.4 GHz IEEE 802.15.4-like radio
# indoors) and the DARPA SubT communication model's defaults (osrf/subt: subt_rf_interface's rf_configuration and
# subt_communication_model's radio_configuration).
CHANNEL_DEFAULTS: dict[str, dict[str, Any]] = {
    "generic": {"bitrate_bps": 250_000, "preamble_s": 160e-6, "overhead_bytes": 24, "tx_power_dbm": 0.0,
                "path_loss_exponent": 3.0, "l0_db": 40.0, "max_range": None, "shadowing_sigma_db": 4.0,
                "noise_floor_dbm": -100.0, "sensitivity_dbm": -95.0, "reception": "step", "sinr_threshold_db": 6.0},
    "subt": {"bitrate_bps": 54_000_000, "preamble_s": 0.0, "overhead_bytes": 0, "tx_power_dbm": 27.0,
             "path_loss_exponent": 2.5, "l0_db": 40.0, "max_range": 50.0, "shadowing_sigma_db": 10.0,
             "noise_floor_dbm": -90.0, "sensitivity_dbm": -90.0, "reception": "qpsk", "sinr_threshold_db": 6.0},
}
CSMA_KEYS = ("cs_threshold_dbm", "backoff_slots", "max_attempts")


def _preset_default(name: str) -> str:
    generic, subt = CHANNEL_DEFAULTS["generic"][name], CHANNEL_DEFAULTS["subt"][name]

    def word(v: Any) -> str:
        return "none" if v is None else f"`{v!r}`" if not isinstance(v, str) else f'`"{v}"`'
    return f"{word(generic)} (`subt`: {word(subt)})"


def _ckey(typ: Any, name: str, meaning: str, **kw) -> Any:
    """A channel key whose default comes from the preset (``CHANNEL_DEFAULTS``)."""
    return key(typ | UnsetType, meaning, default=_preset_default(name), **kw)


class Channel(_Spec):
    """``[radio.channel]``: a shared medium - airtime, contention, interference and path loss (docs/channel.md).

    Keys not given take the preset's value (``CHANNEL_DEFAULTS``); ``check`` fills them in.
    """

    preset: key(Literal["generic", "subt"], "the values of the keys not given: `generic` (a 2.4 GHz IEEE 802.15.4-like "
                "radio indoors) or `subt` (the DARPA SubT communication model's defaults: max range 50, path-loss "
                "exponent 2.5, L0 40 dB at 1 m, σ 10 dB, 27 dBm, noise floor −90 dBm, QPSK, 54 Mbit/s)") = "generic"
    mac: key(Literal["none", "aloha", "slotted", "csma"], "medium access: `none` (frames never interfere: path loss "
             "and noise only), `aloha` (pure ALOHA: send at once), `slotted` (slotted ALOHA: send at the next slot "
             "boundary) or `csma` (carrier sense with random backoff; a frame still deferred at the end of its tick "
             "is dropped as `deferred_too_long`)") = "aloha"
    bitrate_bps: _ckey(Positive, "bitrate_bps", "bits per second: a frame's airtime is `preamble_s` + "
                       "(body bytes + `overhead_bytes`)·8/`bitrate_bps`") = UNSET
    preamble_s: _ckey(number(ge=0), "preamble_s", "seconds of preamble before every frame") = UNSET
    overhead_bytes: _ckey(Annotated[int, Meta(ge=0)], "overhead_bytes", "header and trailer bytes the radio adds to "
                          "every frame body") = UNSET
    tx_power_dbm: _ckey(Number, "tx_power_dbm", "transmit power, dBm, of every robot whose group "
                        "does not set its own `tx_power_dbm`") = UNSET
    path_loss_exponent: _ckey(Positive, "path_loss_exponent", "n of the log-distance path loss: the received power "
                              "is `tx_power_dbm` − `l0_db` − 10·n·log10(d/`d0`) + X, X ~ N(0, σ²)") = UNSET
    l0_db: _ckey(Number, "l0_db", "path loss at the reference distance `d0`, dB") = UNSET
    d0: key(Length, "reference distance of the path loss, metres; closer pairs get the power at `d0`") = 1.0
    unit_m: key(Positive, "metres per length unit of the scenario (positions and ranges)") = 1.0
    max_range: _ckey(Length | None, "max_range", "length units beyond which no power arrives at all (SubT's hard "
                     "limit); frames still reach only robots within their sender's `range`") = UNSET
    shadowing_sigma_db: _ckey(number(ge=0), "shadowing_sigma_db", "σ of the log-normal shadowing X, dB, drawn per "
                              "link (the same both ways) from the run's seed") = UNSET
    wall_loss_db: key(number(ge=0) | None, "with `radio.occlusion`: a link an obstacle blocks loses this many dB "
                      "instead of being cut (an interferer out of its sender's `range` is taken as unobstructed)",
                      default="none (a blocked link is dropped as `occluded`)") = None
    walls: key(Literal["link", "crossing"], "with `wall_loss_db`: `link` - a blocked link loses `wall_loss_db` once, "
               "however many walls it crosses; `crossing` - it loses, for each obstacle it crosses, that obstacle's "
               "`loss_db` (its material), else `wall_loss_db` (a run of blocked map cells is one wall)") = "link"
    shadowing_ticks: key(Annotated[int, Meta(ge=1)], "a link's shadowing stays the same for this many ticks "
                         "(1: a new draw every tick; correlated in time above 1)") = 1
    noise_floor_dbm: _ckey(Number, "noise_floor_dbm", "thermal noise power at a receiver, dBm") = UNSET
    sensitivity_dbm: _ckey(Number, "sensitivity_dbm", "a copy received below this power is dropped as "
                           "`below_sensitivity`") = UNSET
    reception: _ckey(Literal["step", "qpsk"], "reception", "`step`: a copy is received when its SINR over its whole "
                     "airtime reaches `sinr_threshold_db`; `qpsk`: with probability (1 − ½·erfc(√SINR))^bits "
                     "(Gray-coded QPSK, Eb/N0 taken as the SINR, bits the whole frame's)") = UNSET
    sinr_threshold_db: _ckey(Number, "sinr_threshold_db", "`step` reception: the least SINR, dB, a copy needs (a "
                             "stronger frame survives a weaker overlapping one by this margin: capture)") = UNSET
    window_s: key(Positive | None, "lockstep: each frame's send time is drawn uniformly within the first `window_s` "
                  "seconds of its tick (realtime: the sender's own send time)", default="`run.dt`") = None
    aloha_slot_s: key(Positive | None, "`slotted`: the slot length, seconds", default="the airtime of the tick's "
                      "longest frame") = None
    slot_s: key(Positive, "`csma`: the backoff slot, seconds, and the time a radio needs to sense a frame that "
                "started") = 20e-6
    cs_threshold_dbm: key(Number | None, "`csma`: a radio senses the channel busy when a frame on the air reaches it "
                          "at this power or more", default="`sensitivity_dbm`") = None
    backoff_slots: key(Annotated[int, Meta(ge=1, le=65536)], "`csma`: the contention window: after a busy "
                       "sense a frame waits until the channel is free plus a backoff drawn in [0, `backoff_slots`) "
                       "slots") = 16
    max_attempts: key(Annotated[int, Meta(ge=1, le=1000)], "`csma`: a frame that finds the channel busy this many "
                      "times is dropped as `deferred_too_long` (as is one that would start after its tick)") = 32

    def check(self, where: str = "radio.channel") -> None:
        """Fill the keys not given from the preset; the CSMA and slotted keys go with their MAC only."""
        for name, value in CHANNEL_DEFAULTS[self.preset].items():
            if getattr(self, name) is UNSET:
                setattr(self, name, value)
        if self.mac != "csma":
            for name in ("cs_threshold_dbm",):
                if getattr(self, name) is not None:
                    raise SpecError(f"{where}.{name}", 'applies only with mac = "csma"')
        if self.mac != "slotted" and self.aloha_slot_s is not None:
            raise SpecError(f"{where}.aloha_slot_s", 'applies only with mac = "slotted"')
        if self.cs_threshold_dbm is None and self.mac == "csma":
            self.cs_threshold_dbm = self.sensitivity_dbm


# ----------------------------------------------------------------- [radio]
GILBERT_KEYS = ("p_gb", "p_bg", "loss_good", "loss_bad")


class Radio(_Spec):
    """``[radio]``: range, latency, loss and the other rules of the medium (world/radio.py)."""

    range: key(Length, "radio range of every robot whose group does not set its own") = 1.0
    latency: key(Annotated[int, Meta(ge=1)], "lockstep: per-hop latency c in ticks; a frame sent at tick k is "
                 "delivered at tick k + c") = 1
    latency_s: key(Positive, "realtime: maximum per-hop latency c in seconds") = 0.01
    latency_min_s: key(number(ge=0) | None, "realtime: minimum latency, at most `latency_s`; each (frame, receiver) "
                       "latency is drawn uniformly in [`latency_min_s`, `latency_s`]", default="`latency_s`") = None
    loss: key(Probability, "probability that a (frame, receiver) pair is lost") = 0.0
    model: key(Literal["bernoulli", "distance"], "`bernoulli`: loss probability `loss`. `distance`: success "
               "probability e = 1 when d < `delta`, else exp(−`delta`·d/Z) (Z the transmitter's range), times "
               "(1 − `loss`)") = "bernoulli"
    delta: key(Positive, "parameter of the `distance` model") = 0.1
    bandwidth: key(Annotated[int, Meta(ge=0)], "bytes of frame bodies a robot may send per tick; frames beyond are "
                   "dropped as `bandwidth`; 0 = no cap") = 0
    occlusion: key(bool, "an obstacle between two robots (the segment between them overlapping it, in 3-D) blocks the "
                   "link: frames over it are dropped as `occluded` ([Obstacles and maps](#obstacles-and-maps))") = False
    loss_model: key(Literal["bernoulli", "gilbert"], "`bernoulli`: each (frame, receiver) is lost independently with "
                    "probability `loss`. `gilbert`: Gilbert–Elliott bursts (below) take the place of `loss` (which "
                    "must then be 0); they multiply with the `distance` model's e when `model = \"distance\"`") = (
        "bernoulli")
    p_gb: key(Probability | None, "per tick probability that a directed pair's channel goes from Good to Bad",
              default="none (required with `gilbert`)") = None
    p_bg: key(Probability | None, "per tick probability that it goes from Bad back to Good; a burst lasts 1/`p_bg` "
              "ticks on average", default="none (required with `gilbert`)") = None
    loss_good: key(Probability | None, "probability that a frame is lost while its pair is Good",
                   default="`0.0` with `gilbert`") = None
    loss_bad: key(Probability | None, "probability that a frame is lost while its pair is Bad",
                  default="`1.0` with `gilbert`") = None
    rab: key(bool, "every delivered frame carries `frame.rab`, the range and bearing at which its receiver heard it "
             "(always on for receivers with `sensing_frame = \"local\"`); off, it costs nothing") = False
    exclude: key(Literal["overheard", "filter"], "what a broadcast's `exclude` list means. `overheard`: as a real "
                 "radio, the copies to excluded robots are carried like any other (range, occlusion, bandwidth, cuts, "
                 "loss) and one that arrives is recorded as overheard (trace `ovh`, `world.overheard`) but not handed "
                 "to the robot; `filter`: the excluded robots are no receivers at all (the older rule: neither "
                 "delivered, overheard nor dropped)") = "overheard"
    rules: key(Annotated[list[dict[str, Any]], Meta(max_length=MAX_RADIO_RULES)],
               "more rules of the radio, each a table: `use` = the name of a rule registered in the entry-point "
               "group `swarmactors.radio_rules`, `before` = the built-in rule (`dead`, `range`, `occlusion`, "
               "`bandwidth`, `cut`, `mac`, `pathloss`, `sinr`, `loss`) it runs before (default: after them all), "
               "and the rule's own keys ([Radio rules](radio-rules.md))", default="none",
               shape="array of tables") = msgspec.field(default_factory=list)
    channel: key(Channel | None, "a shared medium: airtime, contention (ALOHA, slotted ALOHA, CSMA), interference "
                 "(SINR, capture) and log-distance path loss with shadowing; its keys are below "
                 "([The shared channel](channel.md))", default="none (off)", shape="table") = None

    def check(self) -> None:
        """Check the rules between radio keys; fill the Gilbert-Elliott defaults.

        ``latency_min_s`` <= ``latency_s``; the Gilbert-Elliott keys go with ``loss_model = "gilbert"`` only, which
        needs ``p_gb`` and ``p_bg`` and replaces ``loss`` (then 0); ``loss_good`` defaults to 0, ``loss_bad`` to 1.
        """
        if self.latency_min_s is not None and self.latency_min_s > self.latency_s:
            raise SpecError("radio.latency_min_s", "must not exceed radio.latency_s")
        if self.channel is not None:
            self.channel.check()
            if self.channel.wall_loss_db is not None and not self.occlusion:
                raise SpecError("radio.channel.wall_loss_db", "needs radio.occlusion = true (the links walls block)")
            if self.channel.walls != "link" and self.channel.wall_loss_db is None:
                raise SpecError("radio.channel.walls", "needs wall_loss_db (the loss of a wall without its own "
                                                       "loss_db)")
        if self.loss_model != "gilbert":
            for name in GILBERT_KEYS:
                if getattr(self, name) is not None:
                    raise SpecError(f"radio.{name}", 'is a Gilbert-Elliott parameter: set radio.loss_model = "gilbert"')
            return
        for name in ("p_gb", "p_bg"):
            if getattr(self, name) is None:
                raise SpecError(f"radio.{name}", 'give it (a probability per tick) with loss_model = "gilbert"')
        problem = self.loss_problem(self.loss) if self.loss else None
        if problem:
            raise SpecError("radio.loss", problem)
        self.loss_good = 0.0 if self.loss_good is None else self.loss_good
        self.loss_bad = 1.0 if self.loss_bad is None else self.loss_bad

    @classmethod
    def from_dict(cls, data: dict) -> Radio:
        """A checked ``[radio]`` from its table (defaults filled in), or ``SpecError``."""
        radio = decode(data, cls)
        radio.check()
        return radio

    def loss_problem(self, loss: float) -> str | None:
        """Why the Bernoulli ``loss`` cannot be set to ``loss`` (None if it can): Gilbert-Elliott bursts replace it."""
        if self.loss_model == "gilbert":
            return f'{loss!r}: radio.loss_model is "gilbert": its bursts replace the Bernoulli loss, which stays 0'
        return None

    @property
    def c_min_s(self) -> float:
        """Realtime: the smallest per-hop latency (``latency_min_s``, by default ``latency_s``)."""
        return self.latency_s if self.latency_min_s is None else self.latency_min_s


# ----------------------------------------------------------------- [world]
class WorldObject(_Spec, omit_defaults=True):
    """A named point (a target, a task) that robots read in ``ctx.objects`` and actions can move."""

    name: str
    pos: Point
    known_by: Literal["all", "sensing"] | list[RobotId] = "all"


class CShape(_Spec):
    """Swarm Relays' C-shaped obstacle: three boxes of outer side ``size``, wall ``thickness``, open to ``opening``."""

    center: XY
    size: Length
    thickness: Length
    opening: Literal["+x", "-x", "+y", "-y"] = "+x"


class Obstacle(_Spec):
    """A convex prism: exactly one of ``xy`` (a convex polygon), ``box`` or ``c_shape``, over ``z``.

    ``z`` None is every height. Resolved, every obstacle is an ``xy`` polygon with its ``z``.
    """

    xy: key(Annotated[list[XY], Meta(min_length=3)] | UnsetType, "a convex polygon's vertices, in order",
            rule="must be a polygon: at least 3 vertices [x, y], in order") = UNSET
    box: Annotated[list[XY], Meta(min_length=2, max_length=2)] | UnsetType = UNSET
    c_shape: CShape | UnsetType = UNSET
    z: Interval | None | UnsetType = UNSET
    loss_db: number(ge=0) | UnsetType = UNSET  # radio.channel.walls = "crossing": dB a link crossing it loses

    def check(self, where: str) -> None:
        """Exactly one shape; ``z`` = [z_min, z_max] with z_min < z_max; a box's min < max; 0 < 2 thickness < size."""
        shapes = [name for name in ("xy", "box", "c_shape") if getattr(self, name) is not UNSET]
        if len(shapes) != 1:
            raise SpecError(where, "give exactly one of xy, box or c_shape (and optionally z)")
        if self.z not in (UNSET, None) and not self.z[0] < self.z[1]:
            raise SpecError(f"{where}.z", f"{self.z!r} must be [z_min, z_max] with z_min < z_max")
        if self.box is not UNSET and not all(a < b for a, b in zip(*self.box, strict=True)):
            raise SpecError(f"{where}.box", "must be [[x_min, y_min], [x_max, y_max]] with min < max")
        if self.c_shape is not UNSET and not 2 * self.c_shape.thickness < self.c_shape.size:
            raise SpecError(f"{where}.c_shape", "must have 0 < 2 thickness < size")


class Maze(_Spec):
    """A generated perfect maze: ``cols`` x ``rows`` cells, corridors ``corridor`` grid cells wide."""

    cols: Annotated[int, Meta(ge=1)]
    rows: Annotated[int, Meta(ge=1)]
    seed: int = 0
    corridor: Annotated[int, Meta(ge=1)] = 2
    wall: Annotated[int, Meta(ge=1)] = 1


class MapSource(_Spec):
    """``world.map`` as a table: exactly one of ``file`` (a Moving AI map) or ``maze``, placed by cell and origin."""

    file: str | UnsetType = UNSET
    maze: Maze | UnsetType = UNSET
    cell: key(Positive, "length units per cell") = 1.0
    origin: key(XY, "[x, y] of the map's lower-left corner") = msgspec.field(default_factory=lambda: [0.0, 0.0])
    tree_height: key(Positive | None, "how high `T` cells block (default: every height)") = None

    def check(self) -> None:
        if (self.file is UNSET) == (self.maze is UNSET):
            raise SpecError("world.map", "give exactly one of file or maze")


class World(_Spec):
    """``[world]``: dimension, bounds, obstacles and maps, named objects, the robot cap."""

    dims: key(Literal[2, 3], "dimension of positions and velocities") = 2
    max_robots: key(Annotated[int, Meta(ge=1, le=MAX_ROBOTS_LIMIT)], "robots the run may hold, joins and adds "
                    "included; an add or a join beyond it is refused and counted (`world.refused`)") = MAX_ROBOTS
    bounds: key(Corners | None, "box that positions are kept inside, and the default placement area; give `dims` "
                "coordinates per corner (missing coordinates are 0)", shape="`[[min…], [max…]]`") = None
    objects: key(list[WorldObject], "named points (targets, tasks) that robots read in `ctx.objects` and that `move` "
                 "events and control commands can move; names must be unique. `known_by` says which robots know the "
                 "object: `\"all\"` (default: mission knowledge given to every robot), `\"sensing\"` (only robots "
                 "whose sensing range reaches it, re-judged every tick) or a list of robot ids. A behaviour learns "
                 "nothing of the world it could not sense or was not told.",
                 shape="array of `{name = \"…\", pos = [x, y], known_by = …}`") = []
    obstacles: key(list[Obstacle], "convex obstacles: `{xy = [[x, y], …]}` (a convex polygon, ≥ 3 vertices in "
                   "order), `{box = [[x0, y0], [x1, y1]]}` or `{c_shape = {center, size, thickness, opening}}`, each "
                   "with an optional vertical extent `z = [z_min, z_max]` (default: every height) and `loss_db`, "
                   "the dB a radio link crossing it loses with `radio.channel.walls = \"crossing\"` (its material) "
                   "([Obstacles and maps](#obstacles-and-maps))", shape="array of tables") = []
    map: key(str | dict[str, Any] | None, "a grid map: `\"arena.map\"` (a Moving AI file, relative to the scenario "
             "file), or `{file = …}` / `{maze = {cols, rows, seed, corridor, wall}}` with `cell` (length units per "
             "cell, default 1), `origin` (`[x, y]` of the lower-left corner, default `[0, 0]`) and `tree_height` "
             "(how high `T` cells block; default every height)", shape="file name or table") = None
    blocking: key(bool, "bodies cannot overlap: a step that would make two bodies overlap is not taken (so no "
                  "robot-robot collision happens)") = False

    def check(self) -> None:
        """Bounds: min < max (z: min <= max), padded to ``dims``; objects: unique names, positions padded."""
        if self.bounds is not None:
            lo, hi = self.bounds = points(self.bounds, self.dims, "world.bounds")
            if any(a >= b for a, b in zip(lo[:2], hi[:2], strict=True)) or any(a > b for a, b in zip(lo[2:], hi[2:],
                                                                                                   strict=True)):
                raise SpecError("world.bounds", "must be [[min...], [max...]] with min < max (z: min <= max)")
        names: set[str] = set()
        for i, obj in enumerate(self.objects):
            if obj.name in names:
                raise SpecError(f"world.objects[{i}]", f"duplicate object name {obj.name!r}")
            names.add(obj.name)
            obj.pos = points([obj.pos], self.dims, f"world.objects[{i}].pos")[0]
        for i, ob in enumerate(self.obstacles):
            ob.check(f"world.obstacles[{i}]")

    def space_spec(self) -> dict:
        """The static map as data (``dims``, ``obstacles``, ``map``): transport.space's input, and ``ctx.map``'s."""
        return {"dims": self.dims, "obstacles": msgspec.to_builtins(self.obstacles), "map": self.map}

    @property
    def has_space(self) -> bool:
        """Whether the world has obstacles or a grid map."""
        return bool(self.obstacles or self.map)


def points(value: list[list[float]], dims: int, where: str) -> list[list[float]]:
    """Points of 2 or ``dims`` coordinates as floats of ``dims`` coordinates (a 2-D point in 3-D gets z = 0)."""
    try:
        arr = np.asarray(value, dtype=float)  # every point alike: at once
    except ValueError:  # points of different lengths
        arr = None
    if arr is not None and arr.ndim == 2 and arr.shape[1] in (2, dims):
        return np.hstack([arr, np.zeros((len(arr), dims - arr.shape[1]))]).tolist()
    for i, p in enumerate(value):
        if len(p) not in (2, dims):
            raise SpecError(f"{where}[{i}]", f"{p!r} must have {' or '.join(sorted({'2', str(dims)}))} coordinates")
    return [[float(v) for v in p] + [0.0] * (dims - len(p)) for p in value]


# ----------------------------------------------------------------- [[robots]] and robot specs
NumberOrRange = Number | Interval
# Every parameter a robot has, in the order of a group's and a robot spec's keys: (name, type, default). A group
# (RobotGroup) adds its placement keys before them; a robot spec (RobotSpec) its position.
ROBOT_KEYS: list[tuple[str, Any, Any]] = [
    ("range", key(Length | None, "radio range of these robots; their behaviours read it as `ctx.range`",
                  default="`radio.range`"), None),
    ("sensing", key(Length | None, "sensing range: robots within it appear in `on_tick`'s `sensed` list; behaviours "
                    "read it as `ctx.sensing`", default="the group's `range`"), None),
    ("speed", key(Speed | None, "maximum speed, length units per second", default="no limit"), None),
    ("turn_rate", key(Positive | None, "maximum turn rate, rad per second; makes the robot a unicycle "
                      "([architecture.md](architecture.md#choices-where-the-specification-was-silent))",
                      default="none (holonomic)"), None),
    ("noise", key(Size, "standard deviation of Gaussian noise added to the x and y of every sensed position"), 0.0),
    ("heading", key(Number, "initial heading, radians"), 0.0),
    ("kind", key(Literal["ground", "flying"], "a ground robot is stopped by every obstacle and by water and, in 3-D, "
                 "stays at z = 0; a flying robot crosses every obstacle in a 2-D world and, in 3-D, those whose "
                 "vertical extent does not contain its altitude ([Obstacles and maps](#obstacles-and-maps))"),
     "ground"),
    ("body_radius", key(Size, "the robot's body (a disc, a ball in 3-D); 0 is a point. Bodies are drawn to scale, and "
                        "overlaps are recorded as collisions"), 0.0),
    ("altitude", key(Annotated[list[Size], Meta(min_length=2, max_length=2)] | None, "flying robots in 3-D: the "
                     "altitudes they stay within, [min, max] with 0 ≤ min ≤ max", default="`[0, ∞)`",
                     shape="`[min, max]`"), None),
    ("climb_rate", key(Speed | None, "flying robots in 3-D: maximum vertical speed, length units per second",
                       default="the group's `speed`"), None),
    ("knows_map", key(bool, "the robot is given the static map as prior knowledge: `ctx.map` "
                      "([writing-behaviors.md](writing-behaviors.md#the-context))"), False),
    ("obstacle_rays", key(Annotated[int, Meta(ge=0, le=MAX_OBSTACLE_RAYS)], "the robot senses obstacles along this "
                          "many horizontal range rays, evenly spaced from its heading, up to its sensing range: "
                          "`ctx.rays`"), 0),
    ("behaviors", key(list[BehaviorSpec], "the robot's behaviours (below)", shape="array of tables"), []),
    ("sensing_frame", key(Literal["global", "local"], "`global`: robots sense world positions and know their world "
                          "pose. `local`: situated sensing, below"), "global"),
    ("range_noise", key(Size, "standard deviation (length units) of Gaussian noise on each sensed range (local "
                        "sensing) and on `frame.rab`'s range"), 0.0),
    ("bearing_noise", key(number(ge=0), "standard deviation (radians) of Gaussian noise on each sensed bearing (local "
                          "sensing) and on `frame.rab`'s bearing"), 0.0),
    ("heading_offset", key(NumberOrRange | None, "local sensing only: the offset (radians) between the robot's own "
                           "frame and the world's; a range is drawn per robot from the run's seed",
                           default="`[-π, π]`"), None),
    ("sensing_to", key(Literal["center", "surface"], "`surface`: the sensed vector points to the closest point of the "
                       "other robot's body (its `body_radius`), not its centre"), "center"),
    ("clock_offset", key(number(ge=-MAX_CLOCK_OFFSET_S, le=MAX_CLOCK_OFFSET_S) | Interval, "offset of the robot's own "
                         "clock, seconds; a range [lo, hi] (within the same limits) is drawn per robot from the run's "
                         "seed"), 0.0),
    ("clock_drift", key(number(ge=-MAX_DRIFT_PPM, le=MAX_DRIFT_PPM) | Interval, "drift of the robot's own clock, ppm; "
                        "a range [lo, hi] (within the same limits) is drawn per robot from the run's seed"), 0.0),
    ("tx_power_dbm", key(Number | None, "these robots' transmit power, dBm, on the shared channel "
                         "(`[radio.channel]`; without it the key has no effect)",
                         default="`radio.channel.tx_power_dbm`"), None),
]
ROBOT_FIELDS = tuple(name for name, _, _ in ROBOT_KEYS)
# a robot spec's JSON leaves these out while they are unset (None) or, for the situated keys, at their default
SPARSE = ("speed", "turn_rate", "altitude", "climb_rate", "sensing_frame", "range_noise", "bearing_noise",
          "heading_offset", "sensing_to", "clock_offset", "clock_drift", "tx_power_dbm")
RANGE_LIMITS = {"clock_offset": MAX_CLOCK_OFFSET_S, "clock_drift": MAX_DRIFT_PPM}  # [lo, hi] values within +-limit

PLACEMENT_KEYS: list[tuple[str, Any, Any]] = [
    ("count", key(Annotated[int, Meta(gt=0)] | None, "number of robots, placed by `placement`; give exactly one of "
                  "`count` and `positions`", default="none"), None),
    ("positions", key(list[Point] | None, "explicit positions, one robot each (resolved placement: `\"explicit\"`)",
                      default="none", shape="array of `[x, y]` (or `[x, y, z]`)"), None),
    ("placement", key(Literal["uniform", "grid", "line", "ring", "explicit"], "placement rule for `count` robots "
                      "(below); a resolved scenario says `\"explicit\"` for given `positions`"), "uniform"),
    ("area", key(Corners | None, "placement area; without `area` and `bounds`, the square from the origin with side "
                 "`sqrt(count) · range · 0.6`", default="`world.bounds`", shape="`[[min…], [max…]]`"), None),
    ("connected", key(bool, "redraw the placement until the whole swarm's graph is connected (below)"), False),
    ("spacing", key(Length | None, "distance between neighbours for `grid`, `line` and `ring`",
                    default="`0.9 · range`"), None),
]


class _Robot(msgspec.Struct):
    """The rules of a robot's parameters, shared by a group and a robot spec (both have every ``ROBOT_KEYS`` key)."""

    unknown: ClassVar[str] = "key"

    def check_params(self, where: str, dims: int, radio_range: float) -> None:
        """Fill ``range`` (the radio's) and ``sensing`` (the range); check the rules between the robot's keys.

        ``heading_offset`` applies with ``sensing_frame = "local"`` only; a ``[lo, hi]`` value has lo <= hi; an
        ``altitude`` [min, max] (0 <= min <= max) applies to flying robots in a 3-D world; behaviours are tables
        with ``use`` (a non-empty string) and optionally ``as`` (one too).
        """
        self.range = radio_range if self.range is None else self.range
        self.sensing = self.range if self.sensing is None else self.sensing
        if self.heading_offset is not None and self.sensing_frame != "local":
            raise SpecError(f"{where}.heading_offset", 'applies only with sensing_frame = "local"')
        for name in ("heading_offset", "clock_offset", "clock_drift"):
            value = getattr(self, name)
            if isinstance(value, list):
                if value[0] > value[1]:
                    raise SpecError(f"{where}.{name}", f"{value!r} is a range [lo, hi] with lo > hi")
                limit = RANGE_LIMITS.get(name)
                if limit is not None and max(map(abs, value)) > limit:
                    raise SpecError(f"{where}.{name}", f"{value!r} must be within ±{limit:g}")
        alt = self.altitude
        if alt is not None:
            if alt[0] > alt[1]:
                raise SpecError(f"{where}.altitude", f"{alt!r} must be [min, max] with 0 <= min <= max")
            if dims != 3 or self.kind != "flying":
                raise SpecError(f"{where}.altitude", "applies to flying robots in a 3-D world (world.dims = 3)")
        for i, b in enumerate(self.behaviors):
            if not isinstance(b.get("use"), str) or not b["use"]:
                raise SpecError(f"{where}.behaviors[{i}]", 'must be a table with use = "name" or "module:Class"')
            if "as" in b and not (isinstance(b["as"], str) and b["as"]):
                raise SpecError(f"{where}.behaviors[{i}].as", f"{b['as']!r} must be a non-empty string")

    def check_positions(self, positions: list[list[float]], where: str, dims: int, given: bool) -> list[list[float]]:
        """Positions of these robots as ``dims`` floats each.

        In 3-D a ground robot stays at z = 0 (an explicit position above it is an error, a placed one is lowered)
        and a flying one within its ``altitude``.
        """
        pts = points(positions, dims, where)
        if dims == 3:
            for i, p in enumerate(pts):
                if self.kind == "ground" and p[2] != 0.0:
                    if given:
                        raise SpecError(f"{where}[{i}]", f"a ground robot stays at z = 0, not {p[2]:g} (give the "
                                                         "group kind = \"flying\" to fly)")
                    p[2] = 0.0
                elif self.kind == "flying" and self.altitude is not None and not (
                        self.altitude[0] <= p[2] <= self.altitude[1]):
                    raise SpecError(f"{where}[{i}]", f"altitude {p[2]:g} is outside "
                                                     f"{where.rpartition('.')[0]}.altitude = {self.altitude}")
        return pts

    # what the world reads of a robot: the meaning of an unset cap
    @property
    def speed_cap(self) -> float:
        return math.inf if self.speed is None else float(self.speed)

    @property
    def turn_cap(self) -> float:
        return math.inf if self.turn_rate is None else float(self.turn_rate)

    @property
    def climb_cap(self) -> float:
        """The vertical speed cap: ``climb_rate``, by default the speed cap."""
        return self.speed_cap if self.climb_rate is None else float(self.climb_rate)

    @property
    def altitude_limits(self) -> tuple[float, float]:
        return (0.0, math.inf) if self.altitude is None else (float(self.altitude[0]), float(self.altitude[1]))

    @property
    def frame_offset(self) -> float | list[float]:
        """The heading offset under local sensing: ``heading_offset``, by default drawn in [-pi, pi]."""
        return list(FULL_TURN) if self.heading_offset is None else self.heading_offset


def _struct(name: str, doc: str, fields: list[tuple[str, Any, Any]], **options) -> type:
    mutable = [(n, t, msgspec.field(default_factory=list)) if d == [] else (n, t, d) for n, t, d in fields]
    return msgspec.defstruct(name, mutable, bases=(_Robot,), kw_only=True, forbid_unknown_fields=True, module=__name__,
                             namespace={"__doc__": doc}, **options)


RobotGroup = _struct("RobotGroup", "A ``[[robots]]`` group: how many robots and where (placement keys), and the "
                                   "parameters they share (``ROBOT_KEYS``).", PLACEMENT_KEYS + ROBOT_KEYS)
RobotSpec = _struct("RobotSpec", "One robot: its position and parameters. The robots of a group, of an ``add`` event "
                                 "and of a control ``add`` command are all robot specs (``robot_spec``).",
                    [("pos", key(Point, "the robot's position"), msgspec.NODEFAULT), *ROBOT_KEYS])


_SPARSE_DEFAULTS = {n: d for n, _, d in ROBOT_KEYS if n in SPARSE}


def robots_to_dicts(specs: list) -> list[dict]:
    """Robot specs as data: every key, but the ``SPARSE`` ones only when set (the resolved ``add`` event's form)."""
    out = msgspec.to_builtins(specs)
    for data in out:
        for k, default in _SPARSE_DEFAULTS.items():
            if data[k] is None or data[k] == default:
                del data[k]
    return out


def robot_spec(data: Any, dims: int, radio_range: float, where: str = "") -> Any:
    """A robot to add from ``data`` (a ``RobotSpec`` or a table with ``pos``): checked, with defaults filled in.

    The limits and rules are a group's (``_Robot``): a control ``add`` accepts exactly what a scenario accepts.
    """
    spec = data if isinstance(data, RobotSpec) else decode(data, RobotSpec, where)
    spec.check_params(where, dims, radio_range)
    spec.pos = spec.check_positions([spec.pos], f"{where}.pos" if where else "pos", dims, True)[0]
    return spec


def robot_specs(group: Any) -> list:
    """The robots of a resolved group, one spec each."""
    common = {name: getattr(group, name) for name in ROBOT_FIELDS}
    return [RobotSpec(pos=p, **common) for p in group.positions]


# ----------------------------------------------------------------- world actions: [[events]] and control commands
class MoveArgs(_Spec):
    """Move a named object (a target) to ``pos``."""

    object: str
    pos: Annotated[list[Coord], Meta(min_length=1, max_length=3)]


Kill = RobotId | Annotated[list[RobotId], Meta(min_length=1)]
Adds = Annotated[list[RobotSpec], Meta(min_length=1, max_length=MAX_PER_REQUEST)]
# Every fault/world action, from a scenario's [[events]] or the control queryable: name -> argument type.
ACTIONS: dict[str, Any] = {
    "kill": Kill,
    "kill_fraction": Probability,
    "add": Annotated[list[Any], Meta(min_length=1, max_length=MAX_PER_REQUEST)],  # items: robot_spec
    "cut": list[Pair],
    "restore": list[Pair],
    "partition": list[list[RobotId]],
    "heal": bool,
    "loss": Probability,
    "move": MoveArgs,
    "stop": bool,
}
# What each action expects, in words (error messages and docs).
ACTION_SHAPES = {
    "kill": "a robot id or a list of robot ids",
    "kill_fraction": "a number in [0, 1]",
    "add": f"a list of 1 to {MAX_PER_REQUEST} robot specs, each with pos = [x, y]",
    "cut": "a list of [a, b] robot id pairs",
    "restore": "a list of [a, b] robot id pairs",
    "partition": "a list of lists of robot ids",
    "heal": "true",
    "loss": "a number in [0, 1]",
    "move": "{object = name, pos = [x, y]}",
    "stop": "true",
}


class Event(_Spec):
    """An ``[[events]]`` entry: ``at``, the tick it applies at, and exactly one action (``ACTIONS``)."""

    unknown: ClassVar[str] = "event"
    at: key(Tick, "the tick at which the action applies")
    kill: key(Kill | UnsetType, "crash-stop these robots (cause `killed`); they stop sending and receiving at this "
              "tick", shape="robot id or array of ids") = UNSET
    kill_fraction: key(Probability | UnsetType, "kill `round(p · alive)` alive robots, chosen by the counter-based "
                       "generator from (seed, tick)", shape="number in [0, 1]") = UNSET
    add: key(RobotGroup | Adds | UnsetType, "add robots; their ids continue after the highest id; each goes to the "
             "live host running the fewest robots (at most "
             f"{MAX_PER_REQUEST} an event)", shape="a robot group table (same keys as `[[robots]]`)") = UNSET
    cut: key(list[Pair] | UnsetType, "frames between a and b, both directions, are dropped as `cut`",
             shape="array of `[a, b]` pairs") = UNSET
    restore: key(list[Pair] | UnsetType, "undo `cut` for these pairs", shape="array of `[a, b]` pairs") = UNSET
    partition: key(list[list[RobotId]] | UnsetType, "frames between robots of different groups are dropped as `cut`; "
                   "robots listed nowhere form one more group; replaces any earlier partition",
                   shape="array of arrays of ids") = UNSET
    heal: key(bool | UnsetType, "remove every cut and the partition", shape="`true`") = UNSET
    loss: key(Probability | UnsetType, "set `radio.loss` from now on", shape="number in [0, 1]") = UNSET
    move: key(MoveArgs | UnsetType, "move a world object", shape="`{object = \"name\", pos = [x, y]}`") = UNSET
    stop: key(bool | UnsetType, "end the run after this tick (`stop_reason = \"stopped by scenario\"`)",
              shape="`true`") = UNSET

    @property
    def name(self) -> str:
        """The event's action (``check`` made sure there is exactly one)."""
        return next(n for n in ACTIONS if getattr(self, n) is not UNSET)

    def action(self) -> dict:
        """The action as the world applies it: ``{name: argument}``."""
        return {self.name: getattr(self, self.name)}

    def check(self, where: str) -> None:
        given = [n for n in ACTIONS if getattr(self, n) is not UNSET]
        if len(given) != 1:
            raise SpecError(where, "give exactly one action besides 'at'")
        if type(self.kill) is int:
            self.kill = [self.kill]


def action_problem(action: dict, *, robots: int | None = None, dims: int = 3, objects: set[str] | None = None,
                   radio: Radio | None = None) -> str | None:
    """Why ``action`` (``{name: argument}``) is not a valid world action, or None.

    ``robots`` (how many exist), ``dims``, ``objects`` and ``radio`` add the checks that need the world's state;
    None skips them (a scenario checks robot ids against the robots that exist at the event's tick). An ``add``'s
    robots are checked as a scenario's (``robot_spec``).
    """
    if not isinstance(action, dict) or len(action) != 1 or next(iter(action)) not in ACTIONS:
        names = sorted(action) if isinstance(action, dict) else action
        return f"unknown command {names!r} (known: {', '.join(ACTIONS)})"
    ((name, value),) = action.items()
    try:
        arg = msgspec.convert(value, ACTIONS[name], strict=True)
    except msgspec.ValidationError as exc:
        return f"{name}: {value!r:.200} is not {ACTION_SHAPES[name]} ({exc})"
    if name in ("heal", "stop") and arg is not True:
        return f"{name}: must be true"
    ids: list[int] = []
    if name == "kill":
        ids = [arg] if isinstance(arg, int) else arg
    elif name in ("cut", "restore", "partition"):
        ids = [i for group in arg for i in group]
    elif name == "add":
        for i, spec in enumerate(arg):
            try:
                robot_spec(spec, dims, 1.0, f"[{i}]")
            except SpecError as exc:
                return f"add{exc}"
    elif name == "move":
        if objects is not None and arg.object not in objects:
            return f"move: no object {arg.object!r} (objects: {sorted(objects)})"
        if len(arg.pos) > dims:
            return f"move: pos {arg.pos!r} has more than {dims} coordinates"
    elif name == "loss" and radio is not None:
        problem = radio.loss_problem(arg)
        if problem:
            return f"loss: {problem}"
    if robots is not None:
        bad = [i for i in ids if i >= robots]
        if bad:
            return f"{name}: no robot {bad[0]} (ids 0..{robots - 1})"
    return None


# ----------------------------------------------------------------- the scenario
class Scenario(_Spec, kw_only=True):
    """A whole scenario: ``[run]``, ``[radio]``, ``[world]``, ``[[robots]]``, ``[[events]]``, ``[[checks]]``."""

    unknown: ClassVar[str] = "section"
    run: Run = msgspec.field(default_factory=Run)
    radio: Radio = msgspec.field(default_factory=Radio)
    world: World = msgspec.field(default_factory=World)
    robots: key(Annotated[list[RobotGroup], Meta(min_length=1)], "the robot groups",
                rule="must hold at least one [[robots]] group")
    events: list[Event] = []
    checks: list[CheckSpec] = []
    source: str = "<scenario>"  # where it came from (set when loaded): a file path, "<dict>", "<Scenario name>"

    @classmethod
    def from_dict(cls, data: dict) -> Scenario:
        """A resolved scenario from its data (``to_dict``, result.json's ``scenario``), typed as it was."""
        return decode(data, cls)

    def to_dict(self) -> dict:
        """The resolved scenario as data: result.json's ``scenario`` and the trace header's."""
        out = msgspec.to_builtins(self)
        for ev, data in zip(self.events, out["events"], strict=True):
            if isinstance(ev.add, list):
                data["add"] = robots_to_dicts(ev.add)
        return out

    def check(self) -> None:
        """Check the rules between keys that need no placement.

        Sections, counts within ``world.max_robots``, each group's parameters, each event's action, each check's
        ``use``.
        """
        self.run.check()
        self.radio.check()
        self.world.check()
        self.check_sizes()
        for i, g in enumerate(self.robots):
            check_group(g, f"robots[{i}]", self)
        for i, e in enumerate(self.events):
            e.check(f"events[{i}]")
            if isinstance(e.add, RobotGroup):
                check_group(e.add, f"events[{i}].add", self)
        for i, c in enumerate(self.checks):
            if not isinstance(c.get("use"), str) or not c["use"]:
                raise SpecError(f"checks[{i}]", 'must be a table with use = "family.check" or "module:function"')

    def check_sizes(self) -> None:
        """Robot counts (groups, then ``add`` events) stay within ``world.max_robots``, an add's within 1000.

        Checked before anything is placed, so 10**9 robots are refused at once.
        """
        limit, total = self.world.max_robots, 0
        items = [(f"robots[{i}]", g) for i, g in enumerate(self.robots)]
        items += [(f"events[{i}].add", e.add) for i, e in enumerate(self.events) if e.add is not UNSET]
        for where, g in items:
            if isinstance(g, list):
                n, name = len(g), where
            else:
                n, name = (g.count, f"{where}.count") if g.count is not None else (len(g.positions or []),
                                                                                  f"{where}.positions")
            total += n
            if total > limit:
                raise SpecError(name, f"{n} robots bring the run to {total}, above world.max_robots = {limit}")
            if where.startswith("events") and n > MAX_PER_REQUEST:
                raise SpecError(name, f"{n} robots: an add creates at most {MAX_PER_REQUEST}")

    def check_event_ids(self) -> None:
        """Each event passes the world's own rule for its action (``action_problem``).

        Robot ids must exist when the event applies (robots added by earlier ``add`` events count).
        """
        count = sum(g.count for g in self.robots)
        objects = {o.name for o in self.world.objects}
        for i in sorted(range(len(self.events)), key=lambda k: self.events[k].at):
            e = self.events[i]
            name = e.name
            if name == "add":
                count += len(e.add)
                continue
            problem = action_problem(e.action(), dims=self.world.dims, objects=objects, radio=self.radio)
            if problem:
                raise SpecError(f"events[{i}].{name}", problem.removeprefix(f"{name}: "))
            value = getattr(e, name)
            if name in ("kill", "cut", "restore", "partition"):
                ids = [x for item in value for x in (item if isinstance(item, list) else [item])]
                bad = [x for x in ids if not 0 <= x < count]
                if bad:
                    raise SpecError(f"events[{i}].{name}", f"no robot {bad[0]} at tick {e.at} "
                                                           f"(ids 0..{count - 1} exist then)")

    def robot_specs(self) -> list:
        """Every robot of a resolved scenario, in id order."""
        return [s for g in self.robots for s in robot_specs(g)]


def check_group(group: Any, where: str, sc: Scenario) -> None:
    """A group's own rules: its parameters (``_Robot.check_params``), one of ``count`` or ``positions``.

    ``placement = "explicit"`` goes with positions (a resolved group has both).
    """
    group.check_params(where, sc.world.dims, sc.radio.range)
    if group.placement == "explicit":
        if group.positions is None or group.count not in (None, len(group.positions)):
            raise SpecError(f"{where}.placement", '"explicit" goes with positions (one robot each)')
    elif (group.count is None) == (group.positions is None):
        raise SpecError(where, "give exactly one of count or positions")


# ----------------------------------------------------------------- decoding, with errors naming the key
def decode(data: Any, kind: type, where: str = "") -> Any:
    """``data`` as a ``kind`` (types, limits and defaults), or ``SpecError`` naming the key, the value and the rule."""
    try:
        return msgspec.convert(data, kind, strict=True)
    except msgspec.ValidationError as exc:
        raise explain(str(exc), data, kind, where) from None


_AT = re.compile(r"^(?P<text>.*?)(?: - at `\$(?P<path>[^`]*)`)?$", re.DOTALL)
_STEP = re.compile(r"\.([^.\[]+)|\[(\d+|\.\.\.)\]")


def explain(message: str, data: Any, kind: type, where: str = "") -> SpecError:
    """A ``SpecError`` from msgspec's validation ``message`` (``Expected `int`, got `str` - at `$.run.ticks```)."""
    m = _AT.match(message)
    text, path = m["text"], m["path"] or ""
    steps = [name or (int(i) if i != "..." else None) for name, i in _STEP.findall(path)]
    at = where + "".join(f".{s}" if isinstance(s, str) else f"[{'…' if s is None else s}]" for s in steps)
    at = at.removeprefix(".")
    value, info, extra = _walk(data, _info(kind), steps)
    field = re.match(r"Object (contains unknown|missing required) field `(.+)`", text)
    if field:
        struct, name = _unwrap(_pick(info, value))[0], field[2]
        where_key = f"{at}.{name}" if at else name
        if field[1] == "missing required":
            known = {f.name: _unwrap(f.type)[1] for f in struct.fields}
            return SpecError(where_key, (known.get(name) or {}).get("rule", "is required"))
        known = [f.name for f in struct.fields]
        unknown = getattr(struct.cls, "unknown", "key")
        listed = ", ".join(ACTIONS) if unknown == "event" else ", ".join(sorted(set(known) - {"source"}))
        close = difflib.get_close_matches(name, known, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        return SpecError(where_key, f"unknown {unknown}{hint} (known: {listed})")
    if value is _NOTHING:
        return SpecError(at, text)
    if isinstance(value, float) and not math.isfinite(value):
        return SpecError(at, f"{value!r} is not a finite number")
    if text.startswith("Expected `") and ", got `" in text:
        return SpecError(at, f"{value!r:.200} is a {_kind_name(value)}, expected {_expected(info)}")
    return SpecError(at, f"{value!r:.200} {(extra or {}).get('rule') or _rule(info, value)}")


_NOTHING = object()


@functools.cache
def _info(kind: Any) -> Any:
    return msgspec.inspect.type_info(kind)


def _unwrap(info: Any) -> tuple[Any, dict | None]:
    extra = None
    while isinstance(info, msgspec.inspect.Metadata):
        extra = info.extra or extra
        info = info.type
    return info, extra


def _members(info: Any) -> list:
    info, _ = _unwrap(info)
    return [_unwrap(m)[0] for m in info.types] if isinstance(info, msgspec.inspect.UnionType) else [info]


def _pick(info: Any, value: Any) -> Any:
    """The member of a union that ``value`` belongs to (by its Python type), else the type itself."""
    mi = msgspec.inspect
    wanted = {bool: (mi.BoolType,), int: (mi.IntType, mi.LiteralType), float: (mi.FloatType,),
              str: (mi.StrType, mi.LiteralType), list: (mi.ListType,), dict: (mi.StructType, mi.DictType)}
    members = _members(info)
    return next((m for m in members if isinstance(m, wanted.get(type(value), ()))), members[0])


def _walk(data: Any, info: Any, steps: list) -> tuple[Any, Any, dict | None]:
    """The value at ``steps`` in ``data``, its type info and its key's extra (_NOTHING where it cannot follow)."""
    info, extra = _unwrap(info)
    value = data
    for step in steps:
        info = _pick(info, value)
        try:
            value = value[step]
        except (KeyError, IndexError, TypeError):
            return _NOTHING, info, extra
        if isinstance(info, msgspec.inspect.StructType):
            field = next((f for f in info.fields if f.name == step), None)
            info, extra = _unwrap(field.type) if field else (info, None)
        elif isinstance(info, msgspec.inspect.ListType):  # an item: the key's own rule is not the item's
            info, extra = _unwrap(info.item_type)
        elif isinstance(info, msgspec.inspect.DictType):
            info, extra = _unwrap(info.value_type)
    return value, info, extra


def _kind_name(value: Any) -> str:
    return {dict: "table"}.get(type(value), type(value).__name__)


def _expected(info: Any) -> str:
    mi = msgspec.inspect
    words: list[str] = []
    for m in _members(info):
        word = ("int" if isinstance(m, mi.IntType) else "float" if isinstance(m, mi.FloatType)
                else "bool" if isinstance(m, mi.BoolType) else "str" if isinstance(m, (mi.StrType, mi.LiteralType))
                else "list" if isinstance(m, mi.ListType) else "table" if isinstance(m, (mi.StructType, mi.DictType))
                else None)
        if word and word not in words:
            words.append(word)
    return " or ".join(words)


def _bound(v: float) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _rule(info: Any, value: Any) -> str:
    """The limit ``value`` breaks, in words (from its type's constraints; a number's as a float's)."""
    mi = msgspec.inspect
    members = _members(info)
    t = next((m for m in members if isinstance(m, mi.FloatType)), None) if isinstance(value, (int, float)) else None
    t = t or _pick(info, value)
    if isinstance(t, mi.LiteralType):
        return f"must be one of {', '.join(map(repr, t.values))}"
    if isinstance(t, (mi.IntType, mi.FloatType)):
        lo = t.ge if t.ge is not None and abs(t.ge) < FLOAT_MAX else None
        hi = t.le if t.le is not None and abs(t.le) < FLOAT_MAX else None
        if t.gt is not None:
            return f"must be > {_bound(t.gt)}" + (f" and <= {_bound(hi)}" if hi is not None else "")
        if lo is not None and hi is not None:
            return f"must be in {lo}..{hi}" if isinstance(t, mi.IntType) else f"must be in [{_bound(lo)}, {_bound(hi)}]"
        return f"must be >= {_bound(lo)}" if lo is not None else f"must be <= {_bound(hi)}"
    if isinstance(t, (mi.ListType, mi.StrType)):
        lo, hi = t.min_length, t.max_length
        what = "items" if isinstance(t, mi.ListType) else "characters"
        if lo == hi:
            return f"must hold {lo} {what}"
        return f"must hold {lo or 0} to {hi} {what}" if hi is not None else f"must hold at least {lo} {what}"
    return "is not valid here"


def schema() -> dict:
    """The JSON Schema (draft 07, which TOML editors read) of a scenario file: ``swarmactors schema``.

    A number key is one ``number`` (msgspec's integer-or-float union folded; "finite" needs no bound in JSON).
    """
    _, defs = msgspec.json.schema_components([Scenario, MapSource], ref_template="#/definitions/{name}")
    root = defs.pop("Scenario")
    root["properties"].pop("source")
    defs["World"]["properties"]["map"]["anyOf"] = [{"type": "string"}, {"$ref": "#/definitions/MapSource"},
                                                   {"type": "null"}]
    defs["Event"]["minProperties"] = defs["Event"]["maxProperties"] = 2  # at and exactly one action
    return _fold({"$schema": "http://json-schema.org/draft-07/schema#", **root, "title": "swarmactors scenario",
                  "definitions": defs})


def _fold(node: Any) -> Any:
    """Fold integer-or-number unions into ``number`` and drop the +-FLOAT_MAX bounds, throughout a schema."""
    if isinstance(node, list):
        return [_fold(x) for x in node]
    if not isinstance(node, dict):
        return node
    node = {k: _fold(v) for k, v in node.items() if not (k in ("minimum", "maximum") and abs(v) == FLOAT_MAX)}
    members = node.get("anyOf")
    if members and any(m.get("type") == "number" for m in members):
        members = [m for m in members if m.get("type") != "integer"]
        if len(members) == 1:
            del node["anyOf"]
            node = {**members[0], **node}
        else:
            node["anyOf"] = members
    return node

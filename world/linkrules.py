"""The radio's rules: each one drops some (frame, receiver) pairs of a decision under its cause.

The medium (world/radio.py) lists every candidate pair of the frames under decision (a broadcast: its sender's
reach; an addressed frame: its destination) in a ``Transmissions`` view, then hands the view to its rules in
order; each rule returns a mask of the pairs it drops (``None``: none), the pairs it drops leave the view, and
the next rule sees the rest. The pairs left at the end arrive. Every rule sees all the frames of the decision at
once: a lockstep tick's every transmission, a realtime delivery window's.

The built-in rules, in their order (``PIPELINE``): ``dead`` (an addressed frame to a robot that is dead or does
not exist), ``range`` (an addressed frame to a robot out of its sender's reach), ``occlusion``
(``radio.occlusion``), ``bandwidth`` (``radio.bandwidth``), ``cut`` (cuts and partitions), the shared channel's
``mac``, ``pathloss`` and ``sinr`` (only with ``[radio.channel]``, world/channel.py) and ``loss``
(``radio.loss``, ``radio.model``, ``radio.loss_model``). A scenario adds its own with ``[[radio.rules]]``
(``use`` = the name of a rule registered in the entry-point group ``swarmactors.radio_rules``, ``before`` = a
built-in rule to run before, by default after them all, and the rule's own keys). Names are looked up among
registered entry points only: a scenario never names a module to import.

A rule's random draws must be counter-based (world/rng.py), keyed on (seed, tick, src, seq, dst): the outcome of
a pair is then the same in any batch, order or process layout.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from importlib.metadata import entry_points
from typing import Any, ClassVar

import msgspec
import numpy as np

from transport.scenario import Radio
from transport.severance import Severance
from world import rng
from world.bursts import GilbertElliott
from world.channel import ChannelModel
from world.sensing import Reach

GROUP = "swarmactors.radio_rules"  # entry points of third-party rules: name = "package.module:RuleClass"
RULE_KEYS = ("use", "before")  # the keys of a [[radio.rules]] table that are not the rule's own


class Transmissions:
    """The pairs under decision: pair k is frame ``frames[frame[k]]`` to receiver ``dst[k]``.

    Per frame: ``src``, ``seq``, ``addressed`` (arrays) and ``sizes()`` (body bytes). Per pair: ``frame``, ``dst``,
    ``overheard`` (the receiver is on the broadcast's ``exclude`` list), ``where`` (its index in ``table.nbrs``,
    -1 when the receiver is not in the sender's reach), ``pair_src`` and ``distances()``. The world at the send
    tick: ``table`` (every alive robot's reach, world/sensing.py), ``alive``, ``positions``, ``ranges`` (radio
    range per robot), ``hidden`` (aligned with ``table.nbrs``: links an obstacle blocks; None: none), ``radio``
    (the scenario's ``[radio]``, as the events left it), ``seed`` and ``tx_power`` (per robot, dBm, for the shared
    channel; nan or None: the channel's own). ``shared``: a dict the rules of one decision
    may leave per-frame results in for the rules after them (the channel's schedule of the frames).
    """

    def __init__(self, tick: int, seed: int, radio: Radio, frames: list, table: Reach, alive: np.ndarray,
                 positions: np.ndarray, ranges: np.ndarray, hidden: np.ndarray | None,
                 tx_power: np.ndarray | None = None):
        nf = len(frames)
        self.tick, self.seed, self.radio, self.frames = tick, seed, radio, frames
        self.table, self.alive, self.positions, self.ranges, self.hidden = table, alive, positions, ranges, hidden
        self.tx_power = tx_power  # per robot: transmit power on the shared channel, dBm (nan, None: the channel's)
        self.src = np.fromiter((f.src for f in frames), np.int64, nf)
        self.seq = np.fromiter((f.seq for f in frames), np.int64, nf)
        self.addressed = np.fromiter((f.dst is not None for f in frames), bool, nf)
        self._sizes: np.ndarray | None = None
        empty = np.zeros(0, dtype=np.int64)
        self.frame, self.dst, self.where = empty, empty, empty
        self.overheard = np.zeros(0, dtype=bool)
        self.shared: dict[str, Any] = {}  # what one rule works out for the next ones of this decision (per frame)

    def __len__(self) -> int:
        return len(self.frame)

    def set_pairs(self, frame: np.ndarray, dst: np.ndarray, where: np.ndarray, overheard: np.ndarray) -> None:
        self.frame, self.dst, self.where, self.overheard = frame, dst, where, overheard

    def keep(self, mask: np.ndarray) -> None:
        """Only the pairs where ``mask`` holds stay under decision."""
        self.frame, self.dst, self.where, self.overheard = (
            self.frame[mask], self.dst[mask], self.where[mask], self.overheard[mask])

    @property
    def pair_src(self) -> np.ndarray:
        """Each pair's sender."""
        return self.src[self.frame]

    def sizes(self) -> np.ndarray:
        """Each frame's body length in bytes (the header is not counted)."""
        if self._sizes is None:
            self._sizes = np.fromiter((len(f.body) for f in self.frames), np.int64, len(self.frames))
        return self._sizes

    def distances(self) -> np.ndarray:
        """Each pair's distance between sender and receiver at the send tick."""
        return np.linalg.norm(self.positions[self.dst] - self.positions[self.pair_src], axis=1)


class LinkRule:
    """A rule of the radio: ``apply`` returns the mask of the pairs it drops, counted under ``cause``.

    A third-party rule sets ``name``, ``cause`` and, if it takes keys, ``Config`` (a msgspec Struct: the keys
    of its ``[[radio.rules]]`` table besides ``use`` and ``before``, checked when the scenario is loaded); it is
    built as ``Rule(config)`` once per run and may keep state between calls (``tx.tick`` tells the tick).
    """

    name: ClassVar[str]
    cause: ClassVar[str]
    Config: ClassVar[type[msgspec.Struct] | None] = None

    def __init__(self, config: msgspec.Struct | None = None):
        self.config = config

    def apply(self, tx: Transmissions) -> np.ndarray | None:
        raise NotImplementedError


# --------------------------------------------------------------------------------------- the built-in rules
class Dead(LinkRule):
    """An addressed frame to a robot that does not exist or is dead is dropped as ``dead``."""

    name = cause = "dead"

    def apply(self, tx):
        addressed = tx.addressed[tx.frame]
        if not addressed.any():
            return None
        d = tx.dst[addressed]
        gone = (d < 0) | (d >= len(tx.alive))
        gone[~gone] = ~tx.alive[d[~gone]]
        out = np.zeros(len(tx), dtype=bool)
        out[addressed] = gone
        return out


class Range(LinkRule):
    """An addressed frame to a robot out of its sender's reach is dropped as ``range``.

    A broadcast's candidates are its sender's reach: never dropped here.
    """

    name = cause = "range"

    def apply(self, tx):
        far = tx.where < 0
        return far if far.any() else None


class Occlusion(LinkRule):
    """With ``radio.occlusion``, a link an obstacle blocks (world/space.py) drops its frames as ``occluded``."""

    name = "occlusion"
    cause = "occluded"

    def apply(self, tx):
        if tx.hidden is None or not len(tx):
            return None
        return tx.hidden[tx.where]


class Bandwidth(LinkRule):
    """``radio.bandwidth``: bytes of bodies per robot per tick.

    Every frame sent charges its sender, in sending order, and the pairs of a frame past the cap are dropped as
    ``bandwidth``; the budget is the tick's, however many decisions carry its frames.
    """

    name = cause = "bandwidth"

    def __init__(self, config=None):
        super().__init__(config)
        self._budget = np.zeros(0, dtype=np.int64)  # bytes sent this tick, per robot
        self._tick = -1

    def apply(self, tx):
        if tx.tick != self._tick:
            self._tick = tx.tick
            self._budget = np.zeros(len(tx.alive), dtype=np.int64)
        cap = tx.radio.bandwidth
        if not cap or not len(tx.frames):
            return None
        over = self._charge(tx.src, tx.sizes(), cap)
        if not over.size or not len(tx):
            return None
        return np.isin(tx.frame, over)

    def _charge(self, senders: np.ndarray, size: np.ndarray, cap: int) -> np.ndarray:
        """Add every frame's body to its sender's budget, in order; the frames past the cap."""
        top = int(senders.max()) + 1
        if top > len(self._budget):
            self._budget = np.concatenate([self._budget, np.zeros(top - len(self._budget), dtype=np.int64)])
        order = np.argsort(senders, kind="stable")
        s, z = senders[order], size[order]
        total = np.cumsum(z)
        first = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
        before = np.repeat(total[first] - z[first], np.diff(np.r_[first, len(s)]))
        used = self._budget[s] + total - before
        last = np.r_[first[1:], len(s)] - 1
        self._budget[s[last]] = used[last]
        return np.sort(order[used > cap])


class Cut(LinkRule):
    """A frame over a cut link or between partition groups (transport/severance.py) is dropped as ``cut``."""

    name = cause = "cut"

    def __init__(self, links: Severance):
        super().__init__()
        self.links = links  # the medium's: the cut, restore, partition and heal events change it

    def apply(self, tx):
        if not self.links or not len(tx):
            return None
        return self.links.mask(tx.pair_src, tx.dst)


class Loss(LinkRule):
    """Per pair, lost when the counter-based draw u, keyed on (seed, tick, src, seq, dst), is >= p.

    p is the decoding probability: ``1 - loss`` (``bernoulli``), or the Gilbert-Elliott state of the (src, dst) pair
    (world/bursts.py), times e = 1 when d < delta, else exp(-delta d / Z) with the ``distance`` model (Swarm
    Relays Sec. III-A; Z the transmitter's range).
    """

    name = cause = "loss"

    def __init__(self, radio: Radio, seed: int):
        super().__init__()
        self.bursts = (GilbertElliott(seed, radio.p_gb, radio.p_bg, radio.loss_good, radio.loss_bad)
                       if radio.loss_model == "gilbert" else None)

    def apply(self, tx):
        if not len(tx):
            return None
        p_ok = self.success_probability(tx)
        if p_ok is None:
            return None
        return rng.uniform(tx.seed, rng.LOSS, tx.tick, tx.pair_src, tx.seq[tx.frame], tx.dst) >= p_ok

    def success_probability(self, tx: Transmissions) -> np.ndarray | float | None:
        """Per-pair decoding probability, or None when every frame gets through."""
        cfg = tx.radio
        src = tx.pair_src
        keep = (1.0 - cfg.loss) if self.bursts is None else self.bursts.success_pairs(tx.tick, src, tx.dst)
        if cfg.model == "distance":
            d = tx.distances()
            e = np.where(d < cfg.delta, 1.0, np.exp(-cfg.delta * d / tx.ranges[src]))
            return e * keep
        if self.bursts is not None:
            return keep
        if cfg.loss > 0.0:
            return np.full(len(tx), 1.0 - cfg.loss)
        return None


class Mac(LinkRule):
    """``radio.channel``: medium access (world/channel.py); a frame deferred past its tick loses every copy.

    Its cause is ``deferred_too_long``; the frames' places on the air wait in ``tx.shared`` for ``sinr``.
    """

    name = "mac"
    cause = "deferred_too_long"

    def __init__(self, model: ChannelModel):
        super().__init__()
        self.model = model

    def apply(self, tx):
        on_air = self.model.schedule(tx).on_air
        if not len(tx) or on_air.all():
            return None
        return ~on_air[tx.frame]


class PathLoss(LinkRule):
    """``radio.channel``: a copy too weak to be received is dropped as ``below_sensitivity``.

    Too weak: its received power is below the sensitivity, or noise alone would corrupt it (world/channel.py).
    """

    name = "pathloss"
    cause = "below_sensitivity"

    def __init__(self, model: ChannelModel):
        super().__init__()
        self.model = model

    def apply(self, tx):
        return ~self.model.heard_alone(tx) if len(tx) else None


class Sinr(LinkRule):
    """``radio.channel`` with a MAC: a copy lost to the frames overlapping its airtime is dropped as ``collision``.

    Lost: its SINR fails the reception rule, or its receiver transmits meanwhile (half duplex; world/channel.py).
    """

    name = "sinr"
    cause = "collision"

    def __init__(self, model: ChannelModel):
        super().__init__()
        self.model = model

    def apply(self, tx):
        return ~self.model.heard_among(tx) if len(tx) else None


BUILTIN: dict[str, type[LinkRule]] = {r.name: r for r in (Range, Loss, Cut, Occlusion, Bandwidth, Dead, Mac, PathLoss,
                                                          Sinr)}
# the order the medium runs them in; mac, pathloss and sinr only with radio.channel (sinr: with a MAC)
PIPELINE = ("dead", "range", "occlusion", "bandwidth", "cut", "mac", "pathloss", "sinr", "loss")
CHANNEL_RULES = ("mac", "pathloss", "sinr")
MALFORMED = "malformed"  # the world's own cause: a frame it could not read (never reaches the radio)
DROP_CAUSES: tuple[str, ...] = (*(r.cause for r in BUILTIN.values()), MALFORMED)  # the built-in causes

_causes: list[str] = list(DROP_CAUSES)  # causes as small integers (``Decision.cause``): built-ins, then the rest


def cause_id(cause: str) -> int:
    """The small integer that stands for ``cause`` in this process (a new cause gets the next one)."""
    if cause not in _causes:
        _causes.append(cause)
    return _causes.index(cause)


def cause_name(i: int) -> str:
    return _causes[i]


# ---------------------------------------------------------------------------------- rules a scenario adds
class RuleError(ValueError):
    """A ``[[radio.rules]]`` table that names no registered rule or gives it bad keys: ``key`` names the key."""

    def __init__(self, key: str, problem: str):
        super().__init__(f"{key}: {problem}")
        self.key = key
        self.problem = problem


@cache
def registered() -> dict[str, Any]:
    """Name -> entry point of every rule registered in ``swarmactors.radio_rules``."""
    return {ep.name: ep for ep in entry_points(group=GROUP)}


def rule_class(name: str, key: str = "radio.rules[0].use") -> type[LinkRule]:
    """The registered rule called ``name``: loaded from its entry point, checked to be a ``LinkRule``."""
    ep = registered().get(name) if isinstance(name, str) else None
    if ep is None:
        known = ", ".join(sorted(registered())) or f"none registered in the entry-point group {GROUP}"
        raise RuleError(key, f"unknown radio rule {name!r} (known: {known})")
    try:
        cls = ep.load()
    except Exception as exc:
        raise RuleError(key, f"radio rule {name!r}: cannot load {ep.value}: {exc.__class__.__name__}: {exc}") from None
    if not (isinstance(cls, type) and issubclass(cls, LinkRule)) or cls in BUILTIN.values():
        raise RuleError(key, f"radio rule {name!r}: {ep.value} is not a LinkRule subclass")
    if not isinstance(getattr(cls, "cause", None), str) or not cls.cause:
        raise RuleError(key, f"radio rule {name!r}: {ep.value} names no cause")
    return cls


def build_rule(spec: dict, where: str = "radio.rules[0]") -> tuple[LinkRule, str | None]:
    """The rule a ``[[radio.rules]]`` table asks for, with its ``before`` (a built-in rule's name, or None)."""
    if not isinstance(spec, dict):
        raise RuleError(where, f"expected a table with `use`, got {spec!r}")
    cls = rule_class(spec.get("use"), f"{where}.use")
    before = spec.get("before")
    if before is not None and before not in PIPELINE:
        raise RuleError(f"{where}.before", f"{before!r} is no built-in rule (one of {', '.join(PIPELINE)})")
    own = {k: v for k, v in spec.items() if k not in RULE_KEYS}
    if cls.Config is None:
        if own:
            raise RuleError(f"{where}.{next(iter(own))}", f"radio rule {spec['use']!r} takes no keys")
        return cls(), before
    try:
        config = msgspec.convert(own, cls.Config)
    except msgspec.ValidationError as exc:
        text = str(exc)
        path = text.rpartition(" - at `$.")[2].rstrip("`") if " - at `$." in text else ""
        raise RuleError(f"{where}.{path}" if path else where, text.partition(" - at `")[0]) from None
    return cls(config), before


def pipeline(radio: Radio, seed: int, links: Severance, dt: float = 1.0, realtime: bool = False) -> list[LinkRule]:
    """The medium's rules in order.

    The built-in ones (the channel's with ``radio.channel`` only; ``dt`` and ``realtime``: the run's tick length
    and clock, which the channel needs), with each ``[[radio.rules]]`` rule before its ``before`` (or, without
    one, after them all, in the order given).
    """
    builtin: dict[str, LinkRule] = {"dead": Dead(), "range": Range(), "occlusion": Occlusion(),
                                    "bandwidth": Bandwidth(), "cut": Cut(links), "loss": Loss(radio, seed)}
    if radio.channel is not None:
        model = ChannelModel(radio.channel, seed, dt, realtime)
        builtin["mac"] = Mac(model)
        builtin["pathloss"] = PathLoss(model)
        if radio.channel.mac != "none":
            builtin["sinr"] = Sinr(model)
        if radio.channel.wall_loss_db is not None:  # walls attenuate instead of blocking
            del builtin["occlusion"]
    ahead: dict[str | None, list[LinkRule]] = {}
    for i, spec in enumerate(radio.rules):
        rule, before = build_rule(spec, f"radio.rules[{i}]")
        ahead.setdefault(before, []).append(rule)
    rules: list[LinkRule] = []
    for name in PIPELINE:
        rules.extend(ahead.get(name, ()))
        if name in builtin:
            rules.append(builtin[name])
    rules.extend(ahead.get(None, ()))
    return rules


def check_rules(radio: Radio, problem: Callable[[str, str], Exception]) -> None:
    """Raise ``problem(key, text)`` for the first ``[[radio.rules]]`` table that cannot be built."""
    for i, spec in enumerate(radio.rules):
        try:
            build_rule(spec, f"radio.rules[{i}]")
        except RuleError as exc:
            raise problem(exc.key, exc.problem) from None

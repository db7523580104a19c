"""Finding behaviours, checks and subcommands by name: the registries built from the protocol families.

Every protocol family declares one entry point in the group ``swarmactors.families``, naming its ``Family``
(``swarmactors.robot.family``): ``relays = "protocols.relays.suite:FAMILY"``. The family lists its behaviours
(``use = "relays"``), its checks (``use = "relays.connected"``) and its subcommands (``swarmactors schedule``)
as import paths, loaded only when used. The core's own family (``world.no_collisions``, the ``rl`` behaviour)
is built in. A ``module:attribute`` path imports a user's own class or function directly. The runner never
imports ``protocols`` by name, so dependencies keep flowing ``protocols -> swarmactors``.

A name registered by two families is refused: the later family (the core's and the shipped ones come first,
then the others by name) is not loaded, and
``swarmactors list families`` names both. A family that cannot be loaded (an import error, a ``FAMILY`` that
is not a ``Family``) is reported the same way; the others, and the command line, keep working. The groups of
earlier releases (``swarmactors.behaviors``, ``swarmactors.checks``, ``swarmactors.commands``: one entry
point per behaviour, check or subcommand) are still read, with a DeprecationWarning, and will go.

A robot host builds behaviours from specs that arrive over the wire, so it goes
through ``resolve_behavior``: a spec names a registered behaviour, or a
``module:Class`` whose module the host's operator allowed (``--allow MODULE``,
or the scenario's own modules for ``run``/``world``), and the object must be a
``Behavior`` subclass. Nothing outside that set is imported, let alone called.

A family's pluggable rules (stigmergy's conflict rules, CBAA's scores, ...) are a ``Rules`` registry: a
parameter names a built-in rule or an entry point of the family's group, and is never read as an import path.
No parameter that reaches a robot - from a scenario, a control command or a join reply - becomes code.
"""

from __future__ import annotations

import pkgutil
import sys
import warnings
from collections.abc import Callable, Collection, Iterator, Mapping
from dataclasses import dataclass, field
from functools import cache
from importlib.metadata import entry_points
from typing import Any

from swarmactors.robot.family import CORE, Family

FAMILIES = "swarmactors.families"  # the entry-point group: one entry point per family
BEHAVIORS = "swarmactors.behaviors"  # the registry of behaviours (and the deprecated per-behaviour group)
CHECKS = "swarmactors.checks"  # the registry of checks (and the deprecated per-check group)
COMMANDS = "swarmactors.commands"  # the registry of subcommands (and the deprecated per-subcommand group)
_FIELDS = {BEHAVIORS: "behaviors", CHECKS: "checks", COMMANDS: "commands"}
_WHAT = {BEHAVIORS: "behaviour", CHECKS: "check", COMMANDS: "subcommand"}


class PluginError(LookupError):
    """A behaviour or check name that cannot be resolved."""


@dataclass
class Registry:
    """The loaded families and what they register; ``broken``: family -> why it was not loaded."""

    families: dict[str, Family] = field(default_factory=dict)
    sources: dict[str, str] = field(default_factory=dict)  # family -> where it came from ("module:FAMILY")
    broken: dict[str, str] = field(default_factory=dict)
    names: dict[str, dict[str, tuple[str, str]]] = field(default_factory=dict)  # group -> name -> (target, family)

    def add(self, family: Family, source: str) -> None:
        """Register ``family``, or record why not (a name another family registered, or its own name taken)."""
        if family.name in self.families:
            self.broken[f"{family.name} ({source})"] = (f"family {family.name!r} is already registered by "
                                                        f"{self.sources[family.name]}; refused")
            return
        for group, attr in _FIELDS.items():
            taken = self.names.setdefault(group, {})
            for name in getattr(family, attr):
                if name in taken:
                    self.broken[family.name] = (f"{_WHAT[group]} {name!r} of family {family.name!r} is already "
                                                f"registered by family {taken[name][1]!r}; family "
                                                f"{family.name!r} refused (rename one of them)")
                    return
        self.families[family.name] = family
        self.sources[family.name] = source
        for group, attr in _FIELDS.items():
            for name, target in getattr(family, attr).items():
                self.names[group][name] = (target, family.name)


def _load_family(value: str) -> Family:
    try:
        obj = pkgutil.resolve_name(value)
    except Exception as exc:
        raise PluginError(f"cannot load {value}: {exc.__class__.__name__}: {exc}") from None
    if not isinstance(obj, Family):
        raise PluginError(f"{value} is a {type(obj).__name__}, not a swarmactors.robot.family.Family")
    return obj


def _deprecated_family(dist: str, eps: list) -> Family:
    """The old per-behaviour, per-check and per-subcommand entry points of one distribution, as a family."""
    tables: dict[str, dict[str, str]] = {attr: {} for attr in _FIELDS.values()}
    for ep in eps:
        tables[_FIELDS[ep.group]][ep.name] = ep.value.partition(":")[0] if ep.group == COMMANDS else ep.value
    name = "".join(c if c.isalnum() else "_" for c in dist).lower().strip("_") or "unnamed"
    if not name.isidentifier():
        name = "_" + name
    return Family(name=name, description=f"{dist}'s entry points in the groups of earlier releases (deprecated)",
                  **tables)


def _dist(ep) -> str | None:
    return ep.dist.name if getattr(ep, "dist", None) is not None else None


@cache
def registry() -> Registry:
    """The core family, the shipped families, the installed ones, then the deprecated groups.

    So a name clash never displaces a family shipped with swarmactors: the newcomer is refused.
    """
    reg = Registry()
    reg.add(CORE, "swarmactors.robot.family:CORE")
    for ep in sorted(entry_points(group=FAMILIES), key=lambda e: (_dist(e) != "swarmactors", e.name)):
        try:
            fam = _load_family(ep.value)
        except (PluginError, ValueError) as exc:
            reg.broken[ep.name] = str(exc)
            continue
        if fam.name != ep.name:
            reg.broken[ep.name] = f"{ep.value} is family {fam.name!r}; its entry point must be named {fam.name!r}"
            continue
        reg.add(fam, ep.value)
    old: dict[str, list] = {}
    for group in _FIELDS:
        for ep in entry_points(group=group):
            dist = _dist(ep) or ep.value.partition(".")[0]
            old.setdefault(dist, []).append(ep)
    for dist, eps in sorted(old.items()):
        groups = sorted({ep.group for ep in eps})
        warnings.warn(f"{dist}: entry points in {', '.join(groups)} are deprecated and will be ignored in a "
                      f"later release; declare one family in the group {FAMILIES!r} instead "
                      f"(docs/writing-behaviors.md)", DeprecationWarning, stacklevel=2)
        try:
            reg.add(_deprecated_family(dist, eps), f"{dist} (deprecated entry points)")
        except ValueError as exc:
            reg.broken[dist] = str(exc)
    return reg


def families() -> dict[str, Family]:
    """Every loaded family, by name (the core's first)."""
    return dict(registry().families)


def broken_families() -> dict[str, str]:
    """The families that could not be loaded, with the reason."""
    return dict(registry().broken)


def family_of(group: str, name: str) -> str | None:
    """The family that registers ``name`` in ``group`` (BEHAVIORS, CHECKS or COMMANDS), or None."""
    hit = registry().names.get(group, {}).get(name)
    return hit[1] if hit else None


def available(group: str) -> dict[str, str]:
    """Short name -> import path of everything registered in ``group``; nothing behind them is imported.

    ``group``: BEHAVIORS, CHECKS or COMMANDS (the registries built from the families), FAMILIES (family ->
    where its ``Family`` is), or any other entry-point group (a family's rules: ``swarmactors.cbaa.scores``).
    """
    if group in _FIELDS:
        return {name: target for name, (target, _) in sorted(registry().names.get(group, {}).items())}
    if group == FAMILIES:
        return dict(registry().sources)
    return _entry_points(group)


@cache
def _entry_points(group: str) -> dict[str, str]:
    return {ep.name: ep.value for ep in entry_points(group=group)}


def forget() -> None:
    """Forget the registries, to read the entry points again (after a package was installed in this process)."""
    registry.cache_clear()
    _entry_points.cache_clear()


def resolve(group: str, name: str) -> Any:
    """Import the object behind a short name or a ``module:attr`` path."""
    target = name if ":" in name else available(group).get(name)
    if target is None:
        known = ", ".join(sorted(available(group))) or "none registered"
        broken = registry().broken if group in _FIELDS else {}
        why = "".join(f"; family {f!r} not loaded: {reason}" for f, reason in sorted(broken.items()))
        what = _WHAT.get(group) or group.rsplit(".", 1)[-1].removesuffix("s")
        raise PluginError(f"unknown {what} {name!r} (known: {known}; or give module:Class){why}")
    module_name, _, attr = target.partition(":")
    if not module_name or not attr:
        raise PluginError(f"{name!r}: give module:attribute")
    try:
        return pkgutil.resolve_name(target)
    except AttributeError as exc:
        if module_name in sys.modules:  # the module imported; the attribute is missing
            raise PluginError(f"module {module_name!r} has no attribute {attr!r} (for {name!r})") from None
        raise PluginError(f"cannot import {module_name!r} for {name!r}: {exc.__class__.__name__}: {exc}") from None
    except Exception as exc:
        raise PluginError(f"cannot import {module_name!r} for {name!r}: {exc.__class__.__name__}: {exc}") from None


def family_command(name: str) -> Any:
    """The module behind a registered subcommand: ``add_parser(subparsers)`` adds it, ``command(args)`` runs it.

    A family contributes its own subcommands (TSC's ``schedule``) so the core never imports a protocol.
    """
    target = available(COMMANDS).get(name)
    if target is None:
        raise PluginError(f"unknown subcommand {name!r}")
    try:
        module = pkgutil.resolve_name(target)
    except Exception as exc:
        raise PluginError(f"subcommand {name!r} of family {family_of(COMMANDS, name)!r}: cannot import "
                          f"{target}: {exc.__class__.__name__}: {exc}") from None
    if not (callable(getattr(module, "add_parser", None)) and callable(getattr(module, "command", None))):
        raise PluginError(f"subcommand {name!r}: {module.__name__} has no add_parser and command")
    return module


class RefusedBehavior(PluginError):
    """A behaviour spec outside the host's allowlist, or not naming a Behavior subclass."""


def scenario_modules(specs) -> set[str]:
    """The modules named by ``module:Class`` uses in an iterable of behaviour specs (dicts with ``use``)."""
    return {s["use"].partition(":")[0] for s in specs if isinstance(s.get("use"), str) and ":" in s["use"]}


def allowed(use: Any, allow: Collection[str] = ()) -> bool:
    """True if ``use`` is a registered short name, a registered ``module:attr``, or in an allowed module.

    An allowed module ``pkg`` also allows its submodules ``pkg.sub``.
    """
    if not isinstance(use, str) or not use:
        return False
    registered = available(BEHAVIORS)
    if ":" not in use:
        return use in registered
    if use in registered.values():
        return True
    module = use.partition(":")[0]
    return any(module == m or module.startswith(m + ".") for m in allow)


def resolve_behavior(use: Any, allow: Collection[str] = ()) -> type:
    """The Behavior subclass behind ``use``, refused (RefusedBehavior, nothing imported) outside the allowlist."""
    from swarmactors.robot.behavior import Behavior

    if not allowed(use, allow):
        raise RefusedBehavior(f"refused behaviour {use!r}: not a registered behaviour nor in a module this host "
                              f"allows (allowed modules: {', '.join(sorted(allow)) or 'none'}; see --allow)")
    obj = resolve(BEHAVIORS, use)
    if not (isinstance(obj, type) and issubclass(obj, Behavior)):
        raise RefusedBehavior(f"refused behaviour {use!r}: {type(obj).__name__} {obj!r} is not a Behavior subclass")
    return obj


class UnknownRule(PluginError, ValueError):
    """A rule name that is neither built in nor registered under the family's entry-point group."""


class Rules(Mapping[str, Callable]):
    """A family's pluggable rules, chosen by name: its built-ins, then the entry points of ``group``.

    A name is looked up, never imported as a path ("module:function" is refused like any unknown name), so a
    parameter from a scenario, a control command or a join reply selects only code that the family or an
    installed package registered. Python callers may pass the callable itself instead of a name.
    A third-party rule registers as ``[project.entry-points."<group>"] name = "package.module:function"``.
    """

    def __init__(self, what: str, group: str, builtins: Mapping[str, Callable]):
        self.what, self.group = what, group
        self.builtins = dict(builtins)

    def _registered(self) -> dict[str, str]:
        return {k: v for k, v in available(self.group).items() if k not in self.builtins}

    def __iter__(self) -> Iterator[str]:
        return iter([*self.builtins, *sorted(self._registered())])

    def __len__(self) -> int:
        return len(self.builtins) + len(self._registered())

    def __getitem__(self, name: str) -> Callable:
        if not isinstance(name, str):
            raise KeyError(name)
        if name in self.builtins:
            return self.builtins[name]
        if name in self._registered():
            fn = resolve(self.group, name)
            if not callable(fn):
                raise UnknownRule(f"{self.what} {name!r}: the entry point gives {type(fn).__name__}, not a function")
            return fn
        raise KeyError(name)

    def problem(self, name: object) -> str | None:
        """Why ``name`` does not name a rule of this registry (a parameter's validation), or None."""
        if isinstance(name, str) and name in self:
            return None
        return (f"{self.what} {name!r} is not one of {', '.join(self)} (a rule is chosen by name; register "
                f"your own under the entry-point group {self.group!r}, or pass the function in Python)")

    def get(self, name: str | Callable) -> Callable:  # type: ignore[override]
        """The rule named ``name`` (or ``name`` itself when it is a callable); UnknownRule otherwise."""
        if callable(name):
            return name
        try:
            return self[name]
        except KeyError:
            raise UnknownRule(self.problem(name)) from None

"""Finding behaviours and checks by name.

Short names (``use = "flooding"``, ``use = "flooding.reach"``) are looked up in
the entry-point groups ``swarmactors.behaviors`` and ``swarmactors.checks``,
which the project's ``protocols`` package (and any third-party package)
registers in its pyproject. A ``module:attribute`` path imports a user's own
class or function directly. The runner never imports ``protocols`` by name, so
dependencies keep flowing ``protocols -> swarmactors``.

A robot host builds behaviours from specs that arrive over the wire, so it goes
through ``resolve_behavior``: a spec names a registered entry point, or a
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
from collections.abc import Callable, Collection, Iterator, Mapping
from functools import cache
from importlib.metadata import entry_points
from typing import Any

BEHAVIORS = "swarmactors.behaviors"
CHECKS = "swarmactors.checks"
COMMANDS = "swarmactors.commands"  # a family's subcommands: name = "package.module" with add_parser and command


class PluginError(LookupError):
    """A behaviour or check name that cannot be resolved."""


@cache
def available(group: str) -> dict[str, str]:
    """Short name -> ``module:attr`` for every registered entry point of ``group``."""
    return {ep.name: ep.value for ep in entry_points(group=group)}


def resolve(group: str, name: str) -> Any:
    """Import the object behind a short name or a ``module:attr`` path."""
    target = name if ":" in name else available(group).get(name)
    if target is None:
        known = ", ".join(sorted(available(group))) or "none registered"
        raise PluginError(f"unknown {group.rsplit('.', 1)[-1][:-1]} {name!r} (known: {known}; or give module:Class)")
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
    module = pkgutil.resolve_name(available(COMMANDS)[name])
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
    from swarmactors.behavior import Behavior

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

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
"""

from __future__ import annotations

import pkgutil
import sys
from collections.abc import Collection
from functools import cache
from importlib.metadata import entry_points
from typing import Any

BEHAVIORS = "swarmactors.behaviors"
CHECKS = "swarmactors.checks"


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

"""Finding behaviours and checks by name.

Short names (``use = "flooding"``, ``use = "flooding.reach"``) are looked up in
the entry-point groups ``swarmactors.behaviors`` and ``swarmactors.checks``,
which the project's ``protocols`` package (and any third-party package)
registers in its pyproject. A ``module:attribute`` path imports a user's own
class or function directly. The runner never imports ``protocols`` by name, so
dependencies keep flowing ``protocols -> swarmactors``.
"""

from __future__ import annotations

import importlib
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
    try:
        module = importlib.import_module(module_name)
    except Exception as exc:
        raise PluginError(f"cannot import {module_name!r} for {name!r}: {exc.__class__.__name__}: {exc}") from None
    obj = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise PluginError(f"module {module_name!r} has no attribute {attr!r} (for {name!r})")
        obj = getattr(obj, part)
    return obj

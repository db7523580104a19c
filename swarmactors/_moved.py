"""The module paths of earlier releases, kept working for one more release with a DeprecationWarning.

The core's modules now live in layers (``swarmactors.robot``, ``swarmactors.oracle``, ``swarmactors.runs``,
``swarmactors.tools``). ``import swarmactors.scenario`` and ``from swarmactors.scenario import X`` still work: the
finder below, installed by ``swarmactors/__init__.py``, warns and hands back the module at its new path, so the old
name and the new one are the same module object.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import os
import sys
import warnings

_LAYERS = {
    "robot": ["behavior", "bodies", "family", "host", "hosting", "knownmap", "plugins", "precise_timer",
              "robot_clock", "tasks"],
    "oracle": ["checks", "occlusion_oracle", "result", "trace", "trace_tables", "world_checks"],
    "runs": ["builder", "cluster", "conformance", "inprocess", "launcher", "maps", "progress", "scenario",
             "schema"],
    "tools": ["charts", "draw_space", "export", "foxglove_live", "foxglove_topics", "mcap_export", "newproject",
              "notebook", "plots", "replay", "scene", "see", "suggest", "sweep", "trajectories", "viewer"],
}
MOVED = {f"swarmactors.{leaf}": f"swarmactors.{layer}.{leaf}" for layer, leaves in _LAYERS.items() for leaf in leaves}


_MACHINERY = os.path.dirname(importlib.__file__)  # importlib.import_module and friends


def _bootstrap(frame) -> bool:
    """A frame of the import system's bootstrap, which ``warnings`` skips when it counts a stacklevel."""
    return "importlib" in frame.f_code.co_filename and "_bootstrap" in frame.f_code.co_filename


def _caller_stacklevel() -> int:
    """The stacklevel, from ``_Alias.create_module``, of the line that imports: past this module and importlib."""
    frame, level = sys._getframe(1), 1
    while True:
        frame = frame.f_back
        while frame is not None and _bootstrap(frame):
            frame = frame.f_back
        if frame is None:
            return level
        level += 1
        if frame.f_code.co_filename != __file__ and os.path.dirname(frame.f_code.co_filename) != _MACHINERY:
            return level


class _Alias(importlib.abc.Loader):
    """Loads an old name as the module at its new path (imported first if need be)."""

    def __init__(self, new: str):
        self.new = new

    def create_module(self, spec):
        warnings.warn(f"{spec.name} moved to {self.new}; the old path goes in a later release",
                      DeprecationWarning, stacklevel=_caller_stacklevel())
        module = importlib.import_module(self.new)
        self._spec = module.__spec__
        return module

    def exec_module(self, module) -> None:
        module.__spec__ = self._spec  # the import system set the alias's spec on it; the module keeps its own


class MovedFinder(importlib.abc.MetaPathFinder):
    """Finds the old module paths of ``MOVED``; every other name is left to the next finder."""

    def find_spec(self, fullname, path=None, target=None):
        new = MOVED.get(fullname)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _Alias(new))


def install() -> None:
    """Put the finder on ``sys.meta_path`` (once)."""
    if not any(isinstance(finder, MovedFinder) for finder in sys.meta_path):
        sys.meta_path.append(MovedFinder())

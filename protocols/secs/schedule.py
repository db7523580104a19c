"""Moved to ``protocols.tsc.schedule`` (the family ``tsc``); this old path goes in a later release."""

import importlib
import sys
import warnings

warnings.warn("protocols.secs.schedule moved to protocols.tsc.schedule", DeprecationWarning, stacklevel=2)
sys.modules[__name__] = importlib.import_module("protocols.tsc.schedule")

"""Moved to ``protocols.tsc.schedule_plot`` (the family ``tsc``); this old path goes in a later release."""

import importlib
import sys
import warnings

warnings.warn("protocols.secs.schedule_plot moved to protocols.tsc.schedule_plot", DeprecationWarning, stacklevel=2)
sys.modules[__name__] = importlib.import_module("protocols.tsc.schedule_plot")

"""Moved to ``protocols.tsc.schedule_cli`` (the family ``tsc``); this old path goes in a later release."""

import importlib
import sys
import warnings

warnings.warn("protocols.secs.schedule_cli moved to protocols.tsc.schedule_cli", DeprecationWarning, stacklevel=2)
sys.modules[__name__] = importlib.import_module("protocols.tsc.schedule_cli")

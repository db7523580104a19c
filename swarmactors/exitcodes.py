"""The exit codes of every ``swarmactors`` command, and the rule that gives a run its code (docs/result.md#exit-codes).

A run's code says how it ended, most serious first:

* 130 it was interrupted (SIGINT or SIGTERM): its checks did not run;
* 3 no robot ever ran: none was claimed by a host, or none could be built (a behaviour refused by the host's
  allowlist, a module the host cannot import, a constructor that raised), so nothing was tested;
* 1 a check failed, or a robot crashed: it failed for any cause but ``killed`` (a kill the scenario's events or a
  control command asked for): its hook raised, its step outran the watchdog, its host was lost, its behaviour was
  refused, or it commanded an impossible velocity or position;
* 0 otherwise: every robot that ran kept running, and every check passed (or there were none).

This module imports nothing of the run, so robot hosts may use it.
"""

from __future__ import annotations

from enum import IntEnum


class Exit(IntEnum):
    """What a command's exit status means."""

    OK = 0  # the run finished and every check passed (or the command did what it was asked)
    CHECK = 1  # a check failed, or a robot crashed
    INPUT = 2  # bad input: nothing was started
    RUNTIME = 3  # the run could not complete (robots never claimed, no robot ever ran, the world died, ...)
    INTERRUPTED = 130  # stopped by Ctrl-C (SIGINT) or SIGTERM (docker stop)


EXIT_OK, EXIT_CHECK, EXIT_INPUT, EXIT_RUNTIME, EXIT_INTERRUPTED = (
    Exit.OK, Exit.CHECK, Exit.INPUT, Exit.RUNTIME, Exit.INTERRUPTED)

EXPECTED_FAILURES = frozenset({"killed"})  # causes a scenario asks for: ``kill`` events and control commands


def never_ran(robot: dict) -> bool:
    """A robot (a result.json entry) that no host ever ran: never claimed, or its behaviours never started."""
    return robot.get("host") is None or robot.get("started") is False


def crashed(robot: dict) -> bool:
    """A robot (a result.json entry) that failed for a cause the scenario did not ask for (not ``killed``)."""
    failed = robot.get("failed")
    return bool(failed) and failed.get("cause") not in EXPECTED_FAILURES


def run_exit(result: dict) -> tuple[Exit, str]:
    """A run's exit code from its result.json document, and the reason in a few words."""
    robots = list((result.get("robots") or {}).values())
    if result.get("interrupted"):
        return Exit.INTERRUPTED, f"{result.get('stop_reason') or 'interrupted'}: checks not run"
    if robots and all(never_ran(r) for r in robots):
        unclaimed = sum(r.get("host") is None for r in robots)
        why = (f"no robot host joined ({unclaimed} robots unclaimed)" if unclaimed == len(robots)
               else "every robot failed before its first step")
        return Exit.RUNTIME, f"no robot ever ran: {why}"
    failed_checks = [c for c in result.get("checks") or [] if not c.get("passed")]
    broken = sum(crashed(r) for r in robots)
    reasons = ([f"{broken} robot{'s' if broken != 1 else ''} crashed"] if broken else []) + (
        [f"{len(failed_checks)} check{'s' if len(failed_checks) != 1 else ''} failed"] if failed_checks else [])
    if reasons:
        return Exit.CHECK, ", ".join(reasons)
    return Exit.OK, "every check passed" if result.get("checks") else "no checks"

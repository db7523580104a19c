"""The exit codes of every ``swarmactors`` command (docs/result.md#exit-codes)."""

from enum import IntEnum


class Exit(IntEnum):
    """What a command's exit status means."""

    OK = 0  # the run finished and every check passed (or the command did what it was asked)
    CHECK = 1  # a check failed
    INPUT = 2  # bad input: nothing was started
    RUNTIME = 3  # the run could not complete (robots never claimed, the world died, ...)
    INTERRUPTED = 130  # stopped by Ctrl-C (SIGINT) or SIGTERM (docker stop)


EXIT_OK, EXIT_CHECK, EXIT_INPUT, EXIT_RUNTIME, EXIT_INTERRUPTED = (
    Exit.OK, Exit.CHECK, Exit.INPUT, Exit.RUNTIME, Exit.INTERRUPTED)

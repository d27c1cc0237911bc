"""The three outcomes of an `abb-sim` subcommand other than success, and their exit codes."""

from __future__ import annotations


class UsageError(Exception):
    """Bad command-line input that is not a single parameter (exit code 2)."""


class CommandFailed(Exception):
    """The input was good but the command could not finish, e.g. a full disk (exit code 1)."""


class Terminated(BaseException):
    """SIGTERM arrived (exit code 143): like KeyboardInterrupt, it unwinds every ``finally``."""

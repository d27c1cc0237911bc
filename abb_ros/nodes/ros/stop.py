"""How a node process is asked to stop: SIGINT and SIGTERM set a flag, nothing else.

Installed explicitly, never by an import: by :func:`abb_ros.nodes.ros.script.run_module` before a
node module's imports when it runs as ``python -m abb_ros.nodes.<node>``, and by
:func:`abb_ros.nodes.ros.entry_point.run_node` (which puts the previous handlers back when it
returns).
"""

from __future__ import annotations

import signal
import threading

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class StopRequest:
    """A signal handler that records the first stop signal."""

    def __init__(self):
        self.signum = None

    def __call__(self, signum, _frame) -> None:
        """Record ``signum`` unless a stop signal came already."""
        if self.signum is None:
            self.signum = signum

    def __bool__(self) -> bool:
        return self.signum is not None


REQUEST = StopRequest()


def install() -> dict:
    """Make SIGINT/SIGTERM set :data:`REQUEST`.

    Returns the handlers replaced ({} when already installed or not in the main thread).
    """
    if threading.current_thread() is not threading.main_thread():
        return {}
    if all(signal.getsignal(s) is REQUEST for s in STOP_SIGNALS):
        return {}
    return {s: signal.signal(s, REQUEST) for s in STOP_SIGNALS}



def ignore_from_now_on() -> None:
    """Ignore SIGINT/SIGTERM from here to the end of the process (a node that is exiting).

    ``SIG_IGN`` survives interpreter finalization, which resets Python-level handlers to the
    default action (the process would die of a signal that arrives during teardown).
    """
    if threading.current_thread() is threading.main_thread():
        for signum in STOP_SIGNALS:
            signal.signal(signum, signal.SIG_IGN)

"""How a node process is asked to stop: SIGINT and SIGTERM set a flag, nothing else.

Installed by :func:`abb_ros.nodes.entry_point.run_node`, and already when ``abb_ros.nodes`` is
first imported by a node process (``python -m abb_ros.nodes.<node>`` or the console scripts),
so that a signal during the imports (rclpy, numpy, numba: a second or more under load) is not
a KeyboardInterrupt traceback either: the node then exits 0 without starting. Only the
interpreter's own start-up, before the first line of this package runs, keeps Python's
default handlers.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
NODE_SCRIPTS = ('simulator', 'analysis', 'recorder')


class StopRequest:
    """A signal handler that records the first stop signal."""

    def __init__(self):
        self.signum = None

    def __call__(self, signum, frame) -> None:
        if self.signum is None:
            self.signum = signum

    def __bool__(self) -> bool:
        return self.signum is not None


REQUEST = StopRequest()


def install() -> dict:
    """Make SIGINT/SIGTERM set :data:`REQUEST`; returns the handlers replaced ({} when already
    installed or not in the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    if all(signal.getsignal(s) is REQUEST for s in STOP_SIGNALS):
        return {}
    return {s: signal.signal(s, REQUEST) for s in STOP_SIGNALS}


def starting_a_node() -> bool:
    """True while a node process imports this package: ``python -m abb_ros.nodes.<x>`` (runpy
    sets argv[0] to '-m' while it imports the parent packages) or a node console script."""
    argv0 = sys.argv[0] if sys.argv else ''
    return argv0 == '-m' or os.path.basename(argv0) in NODE_SCRIPTS

"""Start a node process: the stop handlers first, then the node's imports, then its main().

A node module run with ``python -m abb_ros.nodes.<node>`` calls :func:`run_module` before its
own imports, so that SIGINT or SIGTERM while rclpy, numpy and numba load (a second or more
under load) only sets the stop flag (:mod:`abb_ros.nodes.stop`): the node then exits 0
without starting, without a KeyboardInterrupt traceback. Importing a node module installs
nothing.
"""

from __future__ import annotations

import importlib
import sys

from abb_ros.nodes import stop

__all__ = ['run_module']


def run_module(module: str) -> None:
    """Install the stop handlers, import ``module`` and exit with what its main() returns."""
    stop.install()
    sys.exit(importlib.import_module(module).main())

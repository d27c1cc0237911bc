"""Start a node process: the stop handlers first, then the node's imports, then its main().

A node run with ``python -m abb_ros.nodes.<node>`` (its room's ``__main__.py``) calls
:func:`run_module` before the node module's imports, and the console scripts (what ``ros2 run
abb_ros <node>`` and the launch file start) are the functions here named in :data:`NODE_MODULES`.
So SIGINT or SIGTERM while rclpy, numpy and numba load (a second or more under load) only sets the
stop flag (:mod:`abb_ros.nodes.ros.stop`): the node then exits 0 without starting, without a
KeyboardInterrupt traceback. Importing a node module installs nothing.

When main() has returned, SIGINT and SIGTERM are ignored for the rest of the process: at
interpreter finalization CPython puts every signal with a Python handler back to its default
action, so a late second or third SIGINT (a terminal's Ctrl-C reaches the whole process group and
``ros2 launch`` forwards its own) would otherwise kill the exiting node with -2 instead of 0. An
ignored signal stays ignored through finalization.
"""

from __future__ import annotations

import functools
import importlib
import sys

from abb_ros.nodes.ros import stop

__all__ = ['NODE_MODULES', 'run_module', 'simulator', 'analysis', 'recorder',
           'spin_controller']


def run_module(module: str) -> None:
    """Install the stop handlers, import ``module`` and exit with what its main() returns."""
    stop.install()
    try:
        code = importlib.import_module(module).main()
    finally:
        stop.ignore_from_now_on()
    sys.exit(code)


NODE_MODULES = {name: f'abb_ros.nodes.{name}.node'
                for name in ('simulator', 'analysis', 'recorder', 'spin_controller')}
"""The module of each node's console script (setup.py ``entry_points``)."""

simulator = functools.partial(run_module, NODE_MODULES['simulator'])
analysis = functools.partial(run_module, NODE_MODULES['analysis'])
recorder = functools.partial(run_module, NODE_MODULES['recorder'])
spin_controller = functools.partial(run_module, NODE_MODULES['spin_controller'])

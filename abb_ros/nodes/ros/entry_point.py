"""The Jazzy main() of every abb_ros node: init, construct, spin, clean shutdown.

Stopping: SIGINT and SIGTERM only set a flag that the spin loop checks between callbacks
(rclpy's own signal handlers are not installed). A signal therefore never raises inside a
callback, where the EventsExecutor would report ``[FATAL] Exception in 'timers' callback``
with a traceback, and the context is shut down only after the node has been destroyed (its
``close()`` first, e.g. the recorder finishing its bag): exit code 0 and no traceback,
whatever was running when the signal came.
"""

from __future__ import annotations

import os
import signal
import sys

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

from abb_ros.model.parameters.params import ParamError
from abb_ros.nodes.ros import stop as stop_request
from abb_ros.nodes.ros.param_files import ParamFileError, check_arguments

SPIN_TIMEOUT_S = 0.1
"""Longest wait in one spin_once: how late a stop request is seen at worst."""


def make_executor(context):
    """Make rclpy's EventsExecutor for ``context``; ABB_ROS_EXECUTOR=single: the classic one.

    The EventsExecutor is a C++ event loop: about a third of the per-callback overhead of the
    SingleThreadedExecutor, which at 1 kHz decides whether a node keeps real time.
    """
    if os.environ.get('ABB_ROS_EXECUTOR', 'events') == 'single':
        return SingleThreadedExecutor(context=context)
    from rclpy.experimental import EventsExecutor
    return EventsExecutor(context=context)


def spin(node, stop=None) -> None:
    """Spin ``node`` until ``stop`` is set, the context shuts down, or it sets ``exit_code``.

    Timed spin_once calls: the EventsExecutor's own blocking spin does not return on a
    signal (Jazzy).
    """
    executor = make_executor(node.context)
    executor.add_node(node)
    try:
        while not stop and node.context.ok() and getattr(node, 'exit_code', None) is None:
            executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)
    finally:
        executor.remove_node(node)


def run_node(name: str, factory, args=None, usage_errors=(ParamError,), kind=None) -> int:
    """Run the node made by ``factory()`` until SIGINT/SIGTERM or shutdown.

    Installs the stop handlers (:mod:`abb_ros.nodes.ros.stop`) for the time it runs. Returns the
    exit code: 0, the node's ``exit_code`` if it set one (a runtime failure), or 2 with one
    line on stderr when construction raises one of ``usage_errors`` (invalid parameters) or,
    before it, a parameter file or ``-p`` holds what the node would ignore
    (:mod:`abb_ros.nodes.ros.param_files`; ``kind``: the node's entry in
    :data:`abb_ros.nodes.ros.parameter_table.NODES`; None: a node without specs, not checked).
    """
    stop = stop_request.REQUEST
    previous = stop_request.install()
    node = None
    code = 0
    try:
        try:
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        except RuntimeError as err:   # rcl could not parse --ros-args (e.g. -p 'x:=[1')
            print(f'{name}: invalid --ros-args: {str(err).split(", at ")[0]}', file=sys.stderr)
            return 2
        if not stop:   # a signal during the imports: do not start at all
            _check_parameter_files(name, kind, args)
            node = factory()
            spin(node, stop)
        code = getattr(node, 'exit_code', None) or 0
    except ParamFileError as err:
        print(f'{name}: invalid parameters: {err}', file=sys.stderr)
        code = 2
    except usage_errors as err:
        print(f'{name}: invalid parameter: {err}', file=sys.stderr)
        code = 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        # Signals during the tear-down only set the flag again.
        if node is not None:
            close = getattr(node, 'close', None)
            if close is not None:
                close()
            node.destroy_node()
        rclpy.try_shutdown()
        if previous:
            for signum, handler in previous.items():
                signal.signal(signum, handler)
            stop.signum = None
    return code


def _check_parameter_files(name: str, kind: str, args) -> None:
    """Refuse parameter files and ``-p`` of ``args`` (rclpy's: sys.argv) the node would ignore."""
    if kind is None:
        return
    from abb_ros.nodes.ros import parameter_table
    check_arguments(sys.argv if args is None else args, name,
                    parameter_table.specs_for(kind), {s.name for s in parameter_table.SPECS})

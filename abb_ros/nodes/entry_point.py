"""The Jazzy main() of every abb_ros node: init, construct, spin, clean shutdown."""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException

from abb_ros.model.params import ParamError


def run_node(name: str, factory, args=None, spin=rclpy.spin) -> int:
    """Run the node made by ``factory()`` until Ctrl-C or shutdown; return the exit code.

    Invalid start-up parameters (ParamError) print the reason and give exit code 2. SIGINT
    during construction or spinning ends cleanly, without a traceback.
    """
    rclpy.init(args=args)
    node = None
    try:
        node = factory()
        spin(node)
    except ParamError as err:
        print(f'{name}: invalid parameter: {err}', file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0

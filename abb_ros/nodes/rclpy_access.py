"""The parts of rclpy the nodes need that rclpy has no public API for, each in one place.

Checked against rclpy 7.1 (ROS 2 Jazzy). When rclpy gains a public way, switch here.

- :data:`RCLError`: the exception rcl failures raise (an invalid ``--ros-args``, a topic name
  rcl refuses, publishing on a context that was shut down). rclpy defines it only in its C
  extension, ``rclpy._rclpy_pybind11``; ``rclpy.exceptions`` does not re-export it.
- :func:`parameter_overrides`: the start-up parameter values (``-p``, ``--params-file``) of a
  node, by name, before its parameters are declared. rclpy keeps them in
  ``Node._parameter_overrides`` and reads that dict in ``declare_parameter``; there is no
  public getter (``automatically_declare_parameters_from_overrides`` declares them all
  without descriptors, which the nodes cannot use).
- :func:`take_message`: take one queued message of a subscription, with its message info
  (receive time, publication sequence number), outside an executor. rclpy does this only
  inside its executors and ``wait_for_message`` (through the subscription's C handle), and
  the EventsExecutor passes no message info to callbacks.
"""

from __future__ import annotations

from rclpy._rclpy_pybind11 import RCLError
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.subscription import Subscription

__all__ = ['RCLError', 'parameter_overrides', 'take_message']


def parameter_overrides(node: Node) -> dict[str, Parameter]:
    """Return the start-up parameter values of ``node`` by name.

    The dict rclpy declares from: a value written into it is the value the next
    ``declare_parameter`` of that name takes; a name removed from it is declared with its
    default.
    """
    return node._parameter_overrides


def take_message(sub: Subscription):
    """Take the next queued message of ``sub`` as (message, info dict), or None.

    The message is CDR bytes for a ``raw=True`` subscription.
    """
    with sub.handle:
        return sub.handle.take_message(sub.msg_type, sub.raw)

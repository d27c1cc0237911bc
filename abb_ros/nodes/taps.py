"""Subscriptions read in batches, not by callbacks: a hidden helper node no executor spins.

At 1 kHz, one Python callback per message is most of a node's CPU (the executor dispatch
costs more than the work). A node that needs the messages in batches (the recorder) or only
the latest one at its own rate (the analysis node) creates its subscriptions on
:class:`Taps` and takes them from a timer: the middleware queues them (``depth``) meanwhile.
Taking also yields the message info (receive time, publication sequence number), which the
EventsExecutor does not pass to callbacks (Jazzy).
"""

from __future__ import annotations

from rclpy.node import Node

from abb_ros.nodes.rclpy_access import take_message


def _never_called(_data) -> None:
    raise AssertionError('a tap subscription is taken by Taps.take, not called back')


class Taps:
    """Hidden node ``_<owner>_taps`` beside ``owner`` (same context and namespace)."""

    def __init__(self, owner: Node):
        self.node = Node(f'_{owner.get_name()}_taps', namespace=owner.get_namespace(),
                         context=owner.context, start_parameter_services=False,
                         enable_rosout=False)

    def subscribe(self, msg_type, topic: str, qos):
        """Subscribe raw to ``topic``: its CDR bytes are read with :meth:`take`."""
        return self.node.create_subscription(msg_type, topic, _never_called, qos, raw=True)

    @staticmethod
    def take(sub):
        """Take the next queued message as (CDR bytes, info dict), or None."""
        return take_message(sub)

    def destroy(self) -> None:
        """Destroy the helper node and its subscriptions."""
        self.node.destroy_node()

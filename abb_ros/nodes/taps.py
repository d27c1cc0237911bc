"""Subscriptions read in batches, not by callbacks: a hidden helper node that no executor spins.

At 1 kHz, one Python callback per message is most of a node's CPU (the executor dispatch
costs more than the work). A node that needs the messages in batches (the recorder) or only
the latest one at its own rate (the analysis node) creates its subscriptions on
:class:`Taps` and takes them from a timer: the middleware queues them (``depth``) meanwhile.
Taking also yields the message info (receive time, publication sequence number), which the
EventsExecutor does not pass to callbacks (Jazzy).
"""

from __future__ import annotations

from rclpy.node import Node


def _never_called(data) -> None:
    raise AssertionError('a tap subscription is taken by Taps.take, not called back')


class Taps:
    """Hidden node ``_<owner>_taps`` beside ``owner`` (same context and namespace)."""

    def __init__(self, owner: Node):
        self.node = Node(f'_{owner.get_name()}_taps', namespace=owner.get_namespace(),
                         context=owner.context, start_parameter_services=False,
                         enable_rosout=False)

    def subscribe(self, msg_type, topic: str, qos):
        """A raw subscription whose CDR bytes are read with :meth:`take`."""
        return self.node.create_subscription(msg_type, topic, _never_called, qos, raw=True)

    @staticmethod
    def take(sub):
        """The next queued message as (CDR bytes, info dict), or None."""
        with sub.handle:
            return sub.handle.take_message(sub.msg_type, True)

    def destroy(self) -> None:
        self.node.destroy_node()

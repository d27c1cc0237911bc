"""Subscriptions read in batches, not by callbacks: a hidden helper node no executor spins.

At 1 kHz, one Python callback per message is most of a node's CPU (the executor dispatch
costs more than the work). A node that needs the messages in batches (the recorder) or only
the latest one at its own rate (the analysis node) creates its subscriptions on
:class:`Taps` and takes them from a timer: the middleware queues them (``depth``) meanwhile.
Taking also yields the message info (receive time, publication sequence number), which the
EventsExecutor does not pass to callbacks (Jazzy): :meth:`Taps.take` takes it through the
subscription's public ``handle``, as rclpy's own executors and ``wait_for_message`` do.
"""

from __future__ import annotations

from rclpy.node import Node

__all__ = ['Taps', 'helper_name']


def _never_called(_data) -> None:
    raise AssertionError('a tap subscription is taken by Taps.take, not called back')


def helper_name(owner: Node, role: str = '') -> str:
    """Return the hidden helper node's name: ``_<owner>_taps``, ``_<owner>_<role>_taps``.

    Derived from the owner's name in force (after ``-r __node:=NAME``), so a helper is unique
    wherever its owner is, and one per role.
    """
    return f'_{owner.get_name()}_{role}_taps' if role else f'_{owner.get_name()}_taps'


class Taps:
    """Hidden node :func:`helper_name` beside ``owner`` (same context and namespace).

    The command line's ``-r __node:=NAME`` and ``-r __ns:=NS`` (what ``ros2 launch`` passes
    for a node's ``name`` and ``namespace``) apply to every node of the process; the helper's
    own remaps of its name and namespace take precedence over them (rcl reads a node's own
    arguments before the global ones), so it never takes its owner's name. Topic remaps of
    the command line still apply to its subscriptions, as to its owner's.
    """

    def __init__(self, owner: Node, role: str = ''):
        name, namespace = helper_name(owner, role), owner.get_namespace()
        self.node = Node(name, namespace=namespace, context=owner.context,
                         cli_args=['--ros-args', '-r', f'__node:={name}',
                                   '-r', f'__ns:={namespace}'],
                         start_parameter_services=False, enable_rosout=False)

    def subscribe(self, msg_type, topic: str, qos):
        """Subscribe raw to ``topic``: its CDR bytes are read with :meth:`take`."""
        return self.node.create_subscription(msg_type, topic, _never_called, qos, raw=True)

    @staticmethod
    def take(sub):
        """Take the next queued message as (CDR bytes, info dict), or None."""
        with sub.handle:
            return sub.handle.take_message(sub.msg_type, sub.raw)

    def destroy(self) -> None:
        """Destroy the helper node and its subscriptions."""
        self.node.destroy_node()

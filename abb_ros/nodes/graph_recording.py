"""Recording topics of the live graph into a bag: found as they appear, taken in batches.

Used by the recorder node (every topic it records) and by the simulator's in-process
recording (the other nodes' topics, ``record.topics``). Topics are found on the graph
(``get_topic_names_and_types``) and subscribed with ``raw=True`` once a publisher offers them,
with a QoS adapted to the offers as rosbag2 does; the CDR bytes go to the bag unchanged,
stamped with their receive time. The subscriptions belong to a hidden helper node
(:class:`abb_ros.nodes.taps.Taps`) that no executor spins: :meth:`GraphRecording.drain`
takes every queued message of every topic in one batch (with its message info: receive time
and publication sequence number; the EventsExecutor does not pass message info to callbacks
in Jazzy).

Losses: a topic with one publisher numbers its messages (DDS publication sequence number);
every gap after the first message received is a loss. A topic with several publishers cannot
be checked this way (:attr:`GraphRecording.unchecked`).
"""

from __future__ import annotations

import json

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from abb_ros.io import msgdefs
from abb_ros.io.bag_writer import BagWriter
from abb_ros.model.param_spec import ParamError
from abb_ros.nodes.rclpy_access import RCLError
from abb_ros.nodes.taps import Taps

__all__ = ['GraphRecording', 'LossCounter', 'request_qos', 'resolve_topics',
           'SEQUENCE_UNSUPPORTED']

SEQUENCE_UNSUPPORTED = 0
"""rmw's RMW_MESSAGE_INFO_SEQUENCE_NUMBER_UNSUPPORTED."""


class LossCounter:
    """Messages lost on one topic, from the publication sequence numbers of one publisher."""

    def __init__(self):
        self.last = None
        self.lost = 0

    def see(self, sequence: int) -> None:
        if sequence == SEQUENCE_UNSUPPORTED:
            return
        if self.last is not None and sequence > self.last:
            self.lost += sequence - self.last - 1
        self.last = sequence   # smaller: a new publisher (restarted), counted afresh


def request_qos(offered, depth: int) -> QoSProfile:
    """Reliable / transient-local only if every publisher offers it (rosbag2's adaptation)."""
    reliable = all(p.reliability == ReliabilityPolicy.RELIABLE for p in offered)
    latched = all(p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in offered)
    return QoSProfile(
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def resolve_topics(node: Node, topics, param: str) -> set[str]:
    """The full names of ``topics`` in ``node``'s namespace; raises ParamError naming the
    parameter ``param`` for a name that is not a valid ROS topic name."""
    out = set()
    for topic in topics:
        try:
            out.add(node.resolve_topic_name(topic))
        except RCLError as exc:
            why = str(exc).split(', at ')[0]
            raise ParamError(param, topic, "ROS topic names ('stability/margin', "
                             "'/diagnostics', '~/x')", why) from None
    return out


class GraphRecording:
    """Record the topics ``topics`` (names; relative ones resolve in ``node``'s namespace) of
    the graph into ``bag`` (an invalid name: ParamError naming the parameter ``param``).

    own_only : bool
        Whether a topic that only ``node`` itself publishes is recorded (the recorder: no,
        its own ``/diagnostics`` alone is not worth a subscription; the simulator: yes, its
        own messages on a recorded topic then come through the middleware like the others').
    """

    def __init__(self, node: Node, bag: BagWriter, topics, depth: int, own_only: bool = False,
                 param: str = 'topics'):
        self.node = node
        self.bag = bag
        self.wanted = resolve_topics(node, topics, param)
        self.subscriptions: dict[str, object] = {}   # None: not recordable
        self.losses: dict[str, LossCounter] = {}
        self.unchecked: set[str] = set()
        self._publisher_counts: dict[str, int] = {}
        self._depth = depth
        self._own_only = own_only
        self._taps = Taps(node)

    def discover(self) -> None:
        """Subscribe to the wanted topics that publishers now offer."""
        for name in self.losses:
            self._publisher_counts[name] = self.node.count_publishers(name)
        me = (self.node.get_name(), self.node.get_namespace())
        for name, types in self.node.get_topic_names_and_types():
            if name in self.wanted and name not in self.subscriptions and types:
                offered = self.node.get_publishers_info_by_topic(name)
                others = any((i.node_name, i.node_namespace) != me for i in offered)
                if offered and (self._own_only or others):   # none: only subscribers
                    self._subscribe(name, types[0], offered)

    def _subscribe(self, name: str, type_name: str, offered) -> None:
        try:
            cls = msgdefs.message_class(type_name)
        except msgdefs.MessageTypeError as exc:
            self.node.get_logger().warn(f'not recording {name}: {exc}')
            self.subscriptions[name] = None
            return
        digest = str(offered[0].topic_type_hash)
        profiles = [info.qos_profile for info in offered]
        self.bag.add_topic(name, type_name, qos=profiles,
                           type_hash=digest if digest.startswith('RIHS01_') else None)
        self.losses[name] = LossCounter()
        self._publisher_counts[name] = len(offered)
        self.subscriptions[name] = self._taps.subscribe(cls, name,
                                                        request_qos(profiles, self._depth))
        self.node.get_logger().info(f'recording {name} [{type_name}]')

    def drain(self) -> None:
        """Write every message waiting in the subscriptions' queues to the bag. Raises
        :class:`abb_ros.io.bag_writer.BagWriteError` (the bag is then stopped)."""
        for topic, sub in self.subscriptions.items():
            if sub is None:
                continue
            losses = self.losses[topic]
            checked = self._publisher_counts.get(topic, 1) <= 1   # 0: publisher gone
            if not checked:
                self.unchecked.add(topic)
            while (taken := Taps.take(sub)) is not None:
                data, info = taken
                if checked and topic not in self.unchecked:
                    losses.see(info['publication_sequence_number'])
                self.bag.write(topic, data, info['received_timestamp'])

    @property
    def lost(self) -> dict[str, int]:
        """{topic: messages lost} of the topics whose losses can be checked."""
        return {t: c.lost for t, c in self.losses.items() if t not in self.unchecked}

    def write_losses(self) -> None:
        """Into the bag's metadata (custom_data ``abb_ros.lost_messages``: {topic: count};
        ``abb_ros.loss_unchecked``: the topics with several publishers)."""
        self.bag.set_custom_data('abb_ros.lost_messages', json.dumps(self.lost))
        if self.unchecked:
            self.bag.set_custom_data('abb_ros.loss_unchecked', json.dumps(sorted(self.unchecked)))

    def destroy(self) -> None:
        self._taps.destroy()

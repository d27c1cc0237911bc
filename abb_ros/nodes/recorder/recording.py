"""Recording to a bag in process: a node's own messages and topics of the live graph.

Shared by the recorder node (topics of the graph only) and the simulator's in-process
recording (:class:`abb_ros.nodes.simulator.recording.InProcessRecording`: its own messages,
and the other nodes' topics ``record.topics``, started and stopped on request).
:class:`Recording` is one bag being written: a write failure (a full disk) ends it with an
error logged once, the bag readable up to its last chunk; :meth:`Recording.finish` closes it
(summary, ``metadata.yaml``).

Topics of the graph (:class:`GraphRecording`) are found by name
(``get_topic_names_and_types``) and subscribed with ``raw=True`` once a publisher offers
them, with a QoS adapted to the offers as rosbag2 does; the CDR bytes go to the bag
unchanged, stamped with their receive time. The subscriptions belong to a hidden helper node
(:class:`abb_ros.nodes.ros.taps.Taps`) that no executor spins: :meth:`GraphRecording.drain`
takes every queued message of every topic in one batch (with its message info: receive time
and publication sequence number; the EventsExecutor does not pass message info to callbacks
in Jazzy), every :data:`DRAIN_PERIOD_S`.

Losses: a topic with one publisher numbers its messages (DDS publication sequence number);
every gap after the first message received is a loss. A topic with several publishers cannot
be checked this way (:attr:`GraphRecording.unchecked`).
"""

from __future__ import annotations

import json
import time

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from abb_ros.io.bag.writer import BagWriteError, BagWriter
from abb_ros.io.wire import msgdefs
from abb_ros.model.parameters.param_spec import ParamError
from abb_ros.nodes.ros.taps import Taps

__all__ = ['DRAIN_PERIOD_S', 'GraphRecording', 'LossCounter', 'Recording',
           'default_output', 'request_qos', 'resolve_topics', 'refuse_bad_topics',
           'SEQUENCE_UNSUPPORTED']

DRAIN_PERIOD_S = 0.01
"""How often the subscription queues are emptied into the bag [s] (queue_depth messages must
last this long at the topic's rate)."""
SEQUENCE_UNSUPPORTED = 0
"""rmw's RMW_MESSAGE_INFO_SEQUENCE_NUMBER_UNSUPPORTED."""


class LossCounter:
    """Messages lost on one topic, from the publication sequence numbers of one publisher."""

    def __init__(self):
        self.last = None
        self.lost = 0

    def see(self, sequence: int) -> None:
        """Count the gap before publication sequence number ``sequence``."""
        if sequence == SEQUENCE_UNSUPPORTED:
            return
        if self.last is not None and sequence > self.last:
            self.lost += sequence - self.last - 1
        self.last = sequence   # smaller: a new publisher (restarted), counted afresh


def default_output() -> str:
    """Name a bag directory by the local time: ``abb_bag_<date>-<time>``."""
    return time.strftime('abb_bag_%Y_%m_%d-%H_%M_%S')


def request_qos(offered, depth: int) -> QoSProfile:
    """Ask reliable / transient-local only if every publisher offers it (as rosbag2 does)."""
    reliable = all(p.reliability == ReliabilityPolicy.RELIABLE for p in offered)
    latched = all(p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in offered)
    return QoSProfile(
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def resolve_topics(node: Node, topics, param: str) -> set[str]:
    """Resolve ``topics`` in ``node``'s namespace to full names.

    Raises ParamError naming the parameter ``param`` for a name that is not a valid ROS
    topic name.
    """
    out = set()
    for topic in topics:
        try:
            out.add(node.resolve_topic_name(topic))
        except RuntimeError as exc:   # rcl refuses the name
            why = str(exc).split(', at ')[0]
            raise ParamError(param, topic, "ROS topic names ('stability/margin', "
                             "'/diagnostics', '~/x')", why) from None
    return out


def refuse_bad_topics(node: Node, parameters, param: str):
    """Return a refusal if ``parameters`` set ``param`` to a bad topic name, else None.

    The set-parameters check of a topic list (a SetParametersResult naming the parameter), so
    that a bad name is refused when it is set, not when a recording starts.
    """
    from rcl_interfaces.msg import SetParametersResult
    for p in parameters:
        if p.name == param:
            try:
                resolve_topics(node, p.value or [], param)
            except ParamError as err:
                return SetParametersResult(successful=False, reason=str(err))
    return None


class GraphRecording:
    """Record topics of the graph into a bag.

    Parameters
    ----------
    node : Node
        The node recording; relative names resolve in its namespace.
    bag : BagWriter
        The bag written.
    topics : list of str
        The topics recorded (an invalid name: ParamError naming the parameter ``param``).
    depth : int
        Queue depth of each subscription.
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
        self._taps = Taps(node, role=param.rpartition('.')[0].replace('.', '_'))

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
        """Write every message waiting in the subscriptions' queues to the bag.

        Raises :class:`abb_ros.io.bag.writer.BagWriteError` when the bag refuses.
        """
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
        """Messages lost by topic, of the topics whose losses can be checked."""
        return {t: c.lost for t, c in self.losses.items() if t not in self.unchecked}

    def write_losses(self) -> None:
        """Write the losses into the bag's metadata.

        custom_data ``abb_ros.lost_messages``: {topic: count}; ``abb_ros.loss_unchecked``:
        the topics with several publishers.
        """
        self.bag.set_custom_data('abb_ros.lost_messages', json.dumps(self.lost))
        if self.unchecked:
            self.bag.set_custom_data('abb_ros.loss_unchecked', json.dumps(sorted(self.unchecked)))

    def destroy(self) -> None:
        """Destroy the subscriptions."""
        self._taps.destroy()


class Recording:
    """One bag being written by a node: its own messages, and topics of the graph.

    Parameters
    ----------
    node : Node
        The node recording.
    bag : BagWriter
        The bag written.
    topics : list of str or None
        Topics of the graph recorded (:class:`GraphRecording`); None: none.
    depth, own_only, param
        As for :class:`GraphRecording`.
    on_failure : callable or None
        Called with the reason after a write failed (the error is logged already).
    """

    def __init__(self, node: Node, bag: BagWriter, topics=None, depth: int = 10,
                 own_only: bool = False, param: str = 'topics', on_failure=None):
        self.node = node
        self.bag = bag
        self.error = ''
        self.graph = (None if topics is None
                      else GraphRecording(node, bag, topics, depth, own_only, param))
        self._on_failure = on_failure
        self._graph_destroyed = False
        self._own: dict = {}   # the node's own topic -> whether write() records it
        self._queue: list = []   # (topic, CDR bytes, log time) queued by write()

    @property
    def lost_count(self) -> int:
        """Messages lost on the graph's topics, in all."""
        return sum(self.graph.lost.values()) if self.graph is not None else 0

    def discover(self) -> None:
        """Subscribe to the graph's topics that have appeared.

        A topic added to the bag writes its metadata: the disk may refuse.
        """
        self._graph_step(GraphRecording.discover)
        self._own.clear()   # a topic of the node's own may now come from the graph

    @property
    def message_count(self) -> int:
        """Messages recorded so far: given to the bag, or queued for it (:meth:`write`)."""
        return self.bag.message_count + len(self._queue)

    def drain(self) -> None:
        """Write the node's queued messages, then those of the graph's topics, into the bag."""
        self._write_queue()
        self._graph_step(GraphRecording.drain)

    def _write_queue(self) -> None:
        """Write the node's own messages queued by :meth:`write`, in order."""
        if not self._queue or self.error:
            return
        queue, self._queue = self._queue, []
        write = self.bag.write
        try:
            for name, data, stamp_ns in queue:
                write(name, data, stamp_ns)
        except BagWriteError as exc:
            self.failed(exc)

    def _graph_step(self, step) -> None:
        """Run ``step(self.graph)`` unless the recording failed; a write failure ends it."""
        if self.graph is None or self.error:
            return
        try:
            step(self.graph)
        except BagWriteError as exc:
            self.failed(exc)

    def write(self, name: str, type_name: str, qos, data: bytes, stamp_ns: int) -> None:
        """Record one of the node's own messages (CDR bytes) on topic ``name`` at ``stamp_ns``.

        The log time is ``stamp_ns``. A topic recorded from the graph is skipped: the node's
        messages on it come through the middleware like the others'. Called for every
        message the node publishes (5 kHz on the simulator's plant thread), so the message
        is only queued: :meth:`drain` and :meth:`finish` write the queue in order, with the
        same bytes and log times. Whether a topic is recorded is decided once
        (:meth:`_own_topic`), and again after each discovery. After a write failure the
        recording has ended: nothing is queued.
        """
        recorded = self._own.get(name)
        if recorded is None:
            if self.error:
                return
            try:
                recorded = self._own_topic(name, type_name, qos)
            except BagWriteError as exc:
                self.failed(exc)
                return
        if recorded:
            self._queue.append((name, data, stamp_ns))

    def _own_topic(self, name: str, type_name: str, qos) -> bool:
        """Return whether the node's own topic ``name`` is recorded from here (adding it)."""
        recorded = self.graph is None or self.graph.subscriptions.get(name) is None
        if recorded and not self.bag.has_topic(name):
            self.bag.add_topic(name, type_name, qos=qos)
        self._own[name] = recorded
        return recorded

    def failed(self, exc: BagWriteError) -> None:
        """End the recording after a write failure: log it once, tell the owner."""
        self.error = exc.strerror
        self._own = {}     # write() asks again, and sees the error
        self._queue = []
        self.node.get_logger().error(f'recording stopped: {self.error}')
        if self._on_failure is not None:
            self._on_failure(self.error)

    def finish(self) -> str:
        """Finish the bag (summary, metadata.yaml); works after the context has shut down.

        The node's queued messages are written first, then what arrived from the graph since
        the last drain (unless the recording failed or the context is down), then the losses.
        Returns why finishing failed ('' when not).
        """
        if self.bag.closed:
            return ''
        error = ''
        self._write_queue()
        if self.node.context.ok():
            self._graph_step(GraphRecording.drain)
        if self.graph is not None:
            try:
                self.graph.write_losses()
            except BagWriteError as exc:
                error = exc.strerror
        self.destroy()
        try:
            self.bag.close()
        except BagWriteError as exc:
            error = exc.strerror
        return error

    def destroy(self) -> None:
        """Destroy the subscriptions to the graph's topics (once)."""
        if self.graph is not None and not self._graph_destroyed:
            self._graph_destroyed = True
            self.graph.destroy()

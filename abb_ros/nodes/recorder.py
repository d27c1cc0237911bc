"""`recorder` (node ``abb_recorder``): record the abb topics from the live graph to a rosbag2 bag.

Parameters: ``topics`` (names, relative ones resolved in the node's namespace), ``output``
(bag directory; default ``abb_bag_<date>-<time>`` in the working directory), ``chunk_size``,
``compression``, ``queue_depth``, ``discovery_period``. Topics are found on the graph
(``get_topic_names_and_types``) and subscribed with ``raw=True`` once a publisher offers them,
with a QoS adapted to the offers as rosbag2 does; the CDR bytes go to the bag unchanged, stamped
with the node clock (receive time). SIGINT/SIGTERM finish the bag; a full disk ends the
recording with an error, the bag readable up to its last chunk (exit code 1).

Receiving: the subscriptions belong to a hidden helper node (``_<name>_taps``) that no
executor spins; a timer takes every queued message of every topic in one batch each
``DRAIN_PERIOD_S`` (with its message info: receive time and publication sequence number; the
EventsExecutor does not pass message info to callbacks in Jazzy), and once more before the
bag is closed. Losses: a topic with one publisher numbers its messages (DDS publication
sequence number); every gap after the first message received is a loss. Losses are
counted per topic, reported once a second on ``/diagnostics`` (status ``<node>: recording``,
WARN while any message was lost) and written into the bag's metadata (``custom_data``
``abb_ros.lost_messages``: {topic: count}). A topic with several publishers cannot be
checked this way (``abb_ros.loss_unchecked`` lists it).
"""

from __future__ import annotations

import json
import sys
import time

import rclpy.logging
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from abb_ros.io import cdr, msgdefs
from abb_ros.io.bag_writer import BagError, BagWriteError, BagWriter
from abb_ros.model.param_spec import ParamError, specs_for
from abb_ros.nodes import ros_params
from abb_ros.nodes.entry_point import run_node
from abb_ros.nodes.taps import Taps

PARAMS = specs_for('recorder')
"""{ROS name: spec} of the recorder's parameters (abb_ros/model/param_spec.py)."""
DIAGNOSTICS_PERIOD_S = 1.0
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
        if sequence == SEQUENCE_UNSUPPORTED:
            return
        if self.last is not None and sequence > self.last:
            self.lost += sequence - self.last - 1
        self.last = sequence   # smaller: a new publisher (restarted), counted afresh


def default_output() -> str:
    return time.strftime('abb_bag_%Y_%m_%d-%H_%M_%S')


def request_qos(offered, depth: int) -> QoSProfile:
    """Reliable / transient-local only if every publisher offers it (rosbag2's adaptation)."""
    reliable = all(p.reliability == ReliabilityPolicy.RELIABLE for p in offered)
    latched = all(p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in offered)
    return QoSProfile(
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


class Recorder(Node):
    """Subscribe to the wanted topics as they appear and write their CDR bytes to a bag."""

    def __init__(self, **kwargs):
        super().__init__('abb_recorder', **kwargs)
        ros_params.declare(self, PARAMS)
        topics, output, chunk_size, compression, self._depth, period = (
            self.get_parameter(name).value for name in PARAMS)
        self.bag = BagWriter(output or default_output(), chunk_size=chunk_size,
                             compression=compression)
        self._wanted = {self.resolve_topic_name(t) for t in topics}
        self._recorded: dict[str, object] = {}
        self.losses: dict[str, LossCounter] = {}
        self.unchecked: set[str] = set()
        self._publisher_counts: dict[str, int] = {}
        self.exit_code = None
        self.failure = ''
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._taps = Taps(self)
        self.get_logger().info(f'recording {len(self._wanted)} topics to {self.bag.path}')
        self._discover()
        self.create_timer(float(period), self._discover)
        self.create_timer(DRAIN_PERIOD_S, self.drain)
        self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics)

    def _discover(self) -> None:
        for name in self.losses:
            self._publisher_counts[name] = self.count_publishers(name)
        for name, types in self.get_topic_names_and_types():
            if name in self._wanted and name not in self._recorded and types:
                offered = self.get_publishers_info_by_topic(name)
                if any((i.node_name, i.node_namespace) != (self.get_name(),
                                                           self.get_namespace())
                       for i in offered):   # not only this node's own /diagnostics
                    self._subscribe(name, types[0], offered)

    def _subscribe(self, name: str, type_name: str, offered) -> None:
        try:
            cls = msgdefs.message_class(type_name)
        except msgdefs.MessageTypeError as exc:
            self.get_logger().warn(f'not recording {name}: {exc}')
            self._recorded[name] = None
            return
        digest = str(offered[0].topic_type_hash)
        profiles = [info.qos_profile for info in offered]
        self.bag.add_topic(name, type_name, qos=profiles,
                           type_hash=digest if digest.startswith('RIHS01_') else None)
        self.losses[name] = LossCounter()
        self._publisher_counts[name] = len(offered)
        self._recorded[name] = self._taps.subscribe(cls, name,
                                                    request_qos(profiles, self._depth))
        self.get_logger().info(f'recording {name} [{type_name}]')

    def drain(self) -> None:
        """Write every message waiting in the subscriptions' queues to the bag."""
        for topic, sub in self._recorded.items():
            if sub is None:
                continue
            losses = self.losses[topic]
            checked = self._publisher_counts.get(topic, 1) <= 1   # 0: publisher gone
            if not checked:
                self.unchecked.add(topic)
            while self.exit_code is None:
                taken = Taps.take(sub)
                if taken is None:
                    break
                data, info = taken
                if checked and topic not in self.unchecked:
                    losses.see(info['publication_sequence_number'])
                try:
                    self.bag.write(topic, data, info['received_timestamp'])
                except BagWriteError as exc:
                    self.failure = f'recording stopped: {exc.strerror}'
                    self.get_logger().error(self.failure)
                    self.exit_code = 1   # the spin loop ends; close() reports

    @property
    def lost(self) -> dict[str, int]:
        return {t: c.lost for t, c in self.losses.items() if t not in self.unchecked}

    def publish_diagnostics(self) -> None:
        lost = self.lost
        total = sum(lost.values())
        if self.failure:
            level, message = DiagnosticStatus.ERROR, self.failure
        elif total:
            level = DiagnosticStatus.WARN
            message = f'{total} message(s) lost: ' + ', '.join(
                f'{t} {n}' for t, n in lost.items() if n)
        else:
            level, message = DiagnosticStatus.OK, f'recording to {self.bag.path}'
        values = {'recorded': self.bag.message_count, 'lost': total}
        counts = self.bag.topic_counts()
        values.update({f'recorded {t}': counts.get(t, 0) for t in self.losses})
        values.update({f'lost {t}': n for t, n in lost.items()})
        values.update({f'lost {t}': 'unchecked (several publishers)' for t in self.unchecked})
        self._diag_pub.publish(cdr.diagnostics(
            self.get_clock().now().nanoseconds, f'{self.get_fully_qualified_name()}: recording',
            level, message, values))

    def close(self) -> None:
        """Finish the bag (summary, metadata.yaml); works after the context has shut down."""
        logger = rclpy.logging.get_logger(self.get_name())  # not via /rosout, maybe gone
        if not self.bag.closed and self.context.ok():
            self.drain()   # what arrived since the last drain
        if not self.bag.closed:
            try:
                self.bag.set_custom_data('abb_ros.lost_messages', json.dumps(self.lost))
                if self.unchecked:
                    self.bag.set_custom_data('abb_ros.loss_unchecked',
                                             json.dumps(sorted(self.unchecked)))
                self.bag.close()
            except BagWriteError as exc:
                logger.error(f'finishing the bag failed: {exc.strerror}')
        lost = sum(self.lost.values())
        logger.info(
            f'{self.bag.durable_count} messages on {len(self.bag.topics)} topics in '
            f'{self.bag.path}' + (f'; {lost} message(s) lost: {self.lost}' if lost else ''))

    def destroy_node(self):
        self._taps.destroy()
        return super().destroy_node()


def main(args=None) -> int:
    return run_node('abb_recorder', Recorder, args, usage_errors=(ParamError, BagError, OSError))


if __name__ == '__main__':
    sys.exit(main())

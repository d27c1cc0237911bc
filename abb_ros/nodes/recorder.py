"""`recorder` (node ``abb_recorder``): record the abb topics from the live graph to a rosbag2 bag.

Parameters: ``topics`` (names, relative ones resolved in the node's namespace), ``output``
(bag directory; default ``abb_bag_<date>-<time>`` in the working directory), ``chunk_size``,
``compression``, ``queue_depth``, ``discovery_period``. Topics are found on the graph
(``get_topic_names_and_types``) and subscribed with ``raw=True`` once a publisher offers them,
with a QoS adapted to the offers as rosbag2 does; the CDR bytes go to the bag unchanged, stamped
with the node clock (receive time). SIGINT/SIGTERM finish the bag; a full disk ends the
recording with an error, the bag readable up to its last chunk (exit code 1).
"""

from __future__ import annotations

import functools
import sys
import time

import rclpy
import rclpy.logging
from rcl_interfaces.msg import IntegerRange, ParameterDescriptor
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from abb_ros.io import msgdefs
from abb_ros.io.bag_writer import DEFAULT_CHUNK_SIZE, BagError, BagWriteError, BagWriter

DEFAULT_TOPICS = ['joint_states', 'deck/pose', 'deck/twist', 'deck/imu', 'stability/margin',
                  '/diagnostics', 'spindle/speed_cmd', 'spindle/speed', 'visualization/markers']
DEFAULT_QUEUE_DEPTH = 1000  # 1 s of messages at 1 kHz before the middleware drops any


class RecordingStopped(Exception):
    """The bag could not be written any more (e.g. the disk is full)."""


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
        topics = self.declare_parameter(
            'topics', DEFAULT_TOPICS,
            ParameterDescriptor(description='topics to record')).value
        output = self.declare_parameter(
            'output', '', ParameterDescriptor(
                description='bag directory (must not exist); empty: abb_bag_<date>-<time>')).value
        chunk_size = self.declare_parameter(
            'chunk_size', DEFAULT_CHUNK_SIZE, ParameterDescriptor(
                description='MCAP chunk size [bytes]; a crash loses at most one chunk',
                integer_range=[IntegerRange(from_value=256, to_value=1 << 30, step=1)])).value
        compression = self.declare_parameter(
            'compression', 'zstd', ParameterDescriptor(
                description='chunk compression: zstd, lz4 or none')).value
        self._depth = self.declare_parameter(
            'queue_depth', DEFAULT_QUEUE_DEPTH, ParameterDescriptor(
                description='subscription queue depth [messages]',
                integer_range=[IntegerRange(from_value=1, to_value=100000, step=1)])).value
        period = self.declare_parameter(
            'discovery_period', 0.5, ParameterDescriptor(
                description='how often the graph is searched for new topics [s]')).value
        self.bag = BagWriter(output or default_output(), chunk_size=chunk_size,
                             compression=compression)
        self._wanted = {self.resolve_topic_name(t) for t in topics}
        self._recorded: dict[str, object] = {}
        self.get_logger().info(f'recording {len(self._wanted)} topics to {self.bag.path}')
        self._discover()
        self.create_timer(float(period), self._discover)

    def _discover(self) -> None:
        for name, types in self.get_topic_names_and_types():
            if name in self._wanted and name not in self._recorded and types:
                offered = self.get_publishers_info_by_topic(name)
                if offered:
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
        self._recorded[name] = self.create_subscription(
            cls, name, functools.partial(self._on_message, name),
            request_qos(profiles, self._depth), raw=True)
        self.get_logger().info(f'recording {name} [{type_name}]')

    def _on_message(self, topic: str, data: bytes) -> None:
        try:
            self.bag.write(topic, data, self.get_clock().now().nanoseconds)
        except BagWriteError as exc:
            self.get_logger().error(f'recording stopped: {exc.strerror}')
            raise RecordingStopped(str(exc)) from exc

    def close(self) -> None:
        """Finish the bag (summary, metadata.yaml); works after the context has shut down."""
        logger = rclpy.logging.get_logger(self.get_name())  # not via /rosout, maybe gone
        if not self.bag.closed:
            try:
                self.bag.close()
            except BagWriteError as exc:
                logger.error(f'finishing the bag failed: {exc.strerror}')
        logger.info(
            f'{self.bag.message_count} messages on {len(self.bag.topics)} topics in '
            f'{self.bag.path}')


def main(args=None) -> int:
    rclpy.init(args=args)
    node = None
    code = 0
    try:
        node = Recorder()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RecordingStopped:
        code = 1
    except BagError as exc:
        print(f'abb_recorder: error: {exc}', file=sys.stderr)
        code = 2
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == '__main__':
    sys.exit(main())

"""`recorder` (node ``abb_recorder``): record the abb topics from the live graph to a rosbag2 bag.

Parameters: ``topics`` (names, relative ones resolved in the node's namespace), ``output``
(bag directory; default ``abb_bag_<date>-<time>`` in the working directory), ``chunk_size``,
``compression``, ``queue_depth``, ``discovery_period``. Topics are found on the graph
(``get_topic_names_and_types``) and subscribed with ``raw=True`` once a publisher offers them,
with a QoS adapted to the offers as rosbag2 does; the CDR bytes go to the bag unchanged, stamped
with the node clock (receive time). SIGINT/SIGTERM finish the bag; a full disk ends the
recording with an error, the bag readable up to its last chunk (exit code 1).

Receiving (:mod:`abb_ros.nodes.graph_recording`): the subscriptions belong to a hidden
helper node that no executor spins; a timer takes every queued message of every topic in one
batch each ``DRAIN_PERIOD_S``, and once more before the bag is closed. Losses (gaps in a
single publisher's sequence numbers) are counted per topic, reported once a second on
``/diagnostics`` (status ``<node>: recording``, WARN while any message was lost) and written
into the bag's metadata (``custom_data`` ``abb_ros.lost_messages``: {topic: count}; a topic
with several publishers cannot be checked: ``abb_ros.loss_unchecked`` lists it).
"""

from __future__ import annotations

import sys
import time

import rclpy.logging
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.node import Node

from abb_ros.io import cdr
from abb_ros.io.bag_writer import BagError, BagWriteError, BagWriter
from abb_ros.model.param_spec import ParamError
from abb_ros.nodes import ros_params
from abb_ros.nodes.entry_point import run_node
from abb_ros.nodes.graph_recording import GraphRecording, resolve_topics
from abb_ros.nodes.parameter_table import specs_for

__all__ = ['Recorder', 'default_output', 'main']

PARAMS = specs_for('recorder')
"""{ROS name: spec} of the recorder's parameters (abb_ros/nodes/recorder_params.py)."""
DIAGNOSTICS_PERIOD_S = 1.0
DRAIN_PERIOD_S = 0.01
"""How often the subscription queues are emptied into the bag [s] (queue_depth messages must
last this long at the topic's rate)."""


def default_output() -> str:
    return time.strftime('abb_bag_%Y_%m_%d-%H_%M_%S')


class Recorder(Node):
    """Subscribe to the wanted topics as they appear and write their CDR bytes to a bag."""

    def __init__(self, **kwargs):
        super().__init__('abb_recorder', **kwargs)
        ros_params.declare(self, PARAMS)
        topics, output, chunk_size, compression, self._depth, period = (
            self.get_parameter(name).value for name in PARAMS)
        resolve_topics(self, topics, 'topics')     # before the bag: refused, nothing made
        self.bag = BagWriter(output or default_output(), chunk_size=chunk_size,
                             compression=compression)
        self.exit_code = None
        self.failure = ''
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.graph = GraphRecording(self, self.bag, topics, self._depth)
        self.get_logger().info(f'recording {len(self.graph.wanted)} topics to {self.bag.path}')
        self.graph.discover()
        self.create_timer(float(period), self._discover)
        self.create_timer(DRAIN_PERIOD_S, self.drain)
        self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics)

    def _discover(self) -> None:
        """Subscribe to the wanted topics that have appeared (adding one to the bag writes its
        metadata: the disk may refuse)."""
        self._until_failure(self.graph.discover)

    def drain(self) -> None:
        """Write every message waiting in the subscriptions' queues to the bag."""
        self._until_failure(self.graph.drain)

    def _until_failure(self, work) -> None:
        """Run ``work`` unless the bag failed; a write failure ends the node (exit code 1)."""
        if self.exit_code is not None:
            return
        try:
            work()
        except BagWriteError as exc:
            self.failure = f'recording stopped: {exc.strerror}'
            self.get_logger().error(self.failure)
            self.exit_code = 1   # the spin loop ends; close() reports

    @property
    def lost(self) -> dict[str, int]:
        return self.graph.lost

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
        values.update({f'recorded {t}': counts.get(t, 0) for t in self.graph.losses})
        values.update({f'lost {t}': n for t, n in lost.items()})
        values.update({f'lost {t}': 'unchecked (several publishers)'
                       for t in self.graph.unchecked})
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
                self.graph.write_losses()
                self.bag.close()
            except BagWriteError as exc:
                logger.error(f'finishing the bag failed: {exc.strerror}')
        lost = sum(self.lost.values())
        logger.info(
            f'{self.bag.durable_count} messages on {len(self.bag.topics)} topics in '
            f'{self.bag.path}' + (f'; {lost} message(s) lost: {self.lost}' if lost else ''))

    def destroy_node(self):
        self.graph.destroy()
        return super().destroy_node()


def main(args=None) -> int:
    return run_node('abb_recorder', Recorder, args, usage_errors=(ParamError, BagError, OSError))


if __name__ == '__main__':
    sys.exit(main())

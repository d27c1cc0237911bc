"""``recorder`` (node ``abb_recorder``): record the abb topics of the live graph to a bag.

Parameters: ``topics`` (names, relative ones resolved in the node's namespace), ``output``
(bag directory; default ``abb_bag_<date>-<time>`` in the working directory), ``chunk_size``,
``compression``, ``queue_depth``, ``discovery_period``. Topics are found on the graph
(``get_topic_names_and_types``) and subscribed with ``raw=True`` once a publisher offers them,
with a QoS adapted to the offers as rosbag2 does; the CDR bytes go to the bag unchanged, stamped
with the node clock (receive time). SIGINT/SIGTERM finish the bag; a full disk ends the
recording with an error, the bag readable up to its last chunk (exit code 1).

Receiving (:mod:`abb_ros.nodes.recorder.recording`): the subscriptions belong to a hidden helper
node that no executor spins; a timer takes every queued message of every topic in one batch
each ``DRAIN_PERIOD_S``, and once more before the bag is closed. Losses (gaps in a
single publisher's sequence numbers) are counted per topic, reported once a second on
``/diagnostics`` (status ``<node>: recording``, WARN while any message was lost) and written
into the bag's metadata (``custom_data`` ``abb_ros.lost_messages``: {topic: count}; a topic
with several publishers cannot be checked: ``abb_ros.loss_unchecked`` lists it).
"""

from __future__ import annotations

import rclpy
import rclpy.logging
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node

from abb_ros.io.bag.writer import BagError, BagWriter
from abb_ros.io.wire import cdr
from abb_ros.io.wire.topics import DIAGNOSTICS
from abb_ros.model.parameters.param_spec import ParamError
from abb_ros.nodes.recorder.recording import (
    DRAIN_PERIOD_S,
    Recording,
    default_output,
    refuse_bad_topics,
    resolve_topics,
)
from abb_ros.nodes.ros import ros_params
from abb_ros.nodes.ros.entry_point import run_node
from abb_ros.nodes.ros.parameter_table import specs_for

__all__ = ['Recorder', 'main']

PARAMS = specs_for('recorder')
"""{ROS name: spec} of the recorder's parameters (abb_ros/nodes/recorder/params.py)."""
DIAGNOSTICS_PERIOD_S = 1.0


class Recorder(Node):
    """Subscribe to the wanted topics as they appear and write their CDR bytes to a bag."""

    def __init__(self, **kwargs):
        super().__init__('abb_recorder', **kwargs)
        ros_params.declare(self, PARAMS)
        topics, output, chunk_size, compression, self._depth, period = (
            self.get_parameter(name).value for name in PARAMS)
        resolve_topics(self, topics, 'topics')     # before the bag: refused, nothing made
        self.add_on_set_parameters_callback(   # a bad name is refused when set, too
            lambda ps: refuse_bad_topics(self, ps, 'topics') or SetParametersResult(
                successful=True))
        self.bag = BagWriter(output or default_output(), chunk_size=chunk_size,
                             compression=compression)
        self.exit_code = None
        self._diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS, 10)
        self.recording = Recording(self, self.bag, topics, self._depth,
                                   on_failure=self._on_failure)
        self.graph = self.recording.graph
        self.get_logger().info(f'recording {len(self.graph.wanted)} topics to {self.bag.path}')
        self.recording.discover()
        self.create_timer(float(period), self.recording.discover)
        self.create_timer(DRAIN_PERIOD_S, self.recording.drain)
        self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics)

    def _on_failure(self, _reason: str) -> None:
        """End the node after a write failure (exit code 1): the spin loop ends, close()."""
        self.exit_code = 1

    @property
    def lost(self) -> dict[str, int]:
        """Messages lost by topic (the topics whose losses can be checked)."""
        return self.graph.lost

    def publish_diagnostics(self) -> None:
        """Publish the recording status: what was recorded and lost, by topic."""
        lost = self.lost
        total = sum(lost.values())
        if self.recording.error:
            level = DiagnosticStatus.ERROR
            message = f'recording stopped: {self.recording.error}'
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
        error = self.recording.finish()
        if error:
            logger.error(f'finishing the bag failed: {error}')
        lost = sum(self.lost.values())
        logger.info(
            f'{self.bag.durable_count} messages on {len(self.bag.topics)} topics in '
            f'{self.bag.path}' + (f'; {lost} message(s) lost: {self.lost}' if lost else ''))

    def destroy_node(self):
        """Destroy the subscriptions' helper node, then this node."""
        self.recording.destroy()
        return super().destroy_node()


def main(args=None) -> int:
    """Run the recorder until SIGINT/SIGTERM or a write failure; return the exit code."""
    return run_node('abb_recorder', Recorder, args, usage_errors=(ParamError, BagError, OSError),
                    kind='recorder')


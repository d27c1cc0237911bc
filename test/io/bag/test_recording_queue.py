"""A node's own messages recorded in process: queued as they are published, written by the drain.

:meth:`abb_ros.nodes.recorder.recording.Recording.write` runs on the simulator's plant thread for
every message it publishes; it only queues the message, and the drain (or the end of the recording)
writes the queue. These tests hold the bag to what the node gave, in order, with the same bytes and
log times, and a refused write to one failure, reported once.
"""

import errno
import os

import pytest
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from test_bag import _Quota  # a file on which the disk fills up

from abb_ros.io.bag.reader import iter_raw
from abb_ros.io.bag.writer import BagWriter
from abb_ros.io.wire import cdr
from abb_ros.nodes.recorder.recording import Recording

pytestmark = pytest.mark.ros

QOS = QoSProfile(depth=1000)
TOPICS = (('/ns/spindle/speed', 'std_msgs/msg/Float64'), ('/ns/clock', 'rosgraph_msgs/msg/Clock'))


@pytest.fixture
def node():
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    made = Node('recording_queue_test', context=ctx)
    try:
        yield made
    finally:
        made.destroy_node()
        rclpy.shutdown(context=ctx)


def messages(count):
    """(topic, type, CDR bytes, stamp) of ``count`` samples of two topics, as a node sends."""
    out = []
    for i in range(count):
        stamp = 1_000_000_000 + i * 1_000_000
        out.append((*TOPICS[0], cdr.float64(0, 0, float(i)), stamp))
        out.append((*TOPICS[1], cdr.clock(*divmod(stamp, 1_000_000_000)), stamp))
    return out


def test_own_messages_reach_the_bag_at_the_drain_in_order_with_their_bytes_and_log_times(
        node, tmp_path):
    recording = Recording(node, BagWriter(tmp_path / 'bag'))
    sent = messages(300)
    for name, type_name, data, stamp in sent[:200]:
        recording.write(name, type_name, QOS, data, stamp)
    assert recording.bag.message_count == 0 and recording.message_count == 200
    recording.drain()
    assert recording.bag.message_count == recording.message_count == 200
    for name, type_name, data, stamp in sent[200:]:
        recording.write(name, type_name, QOS, data, stamp)
    assert recording.finish() == ''   # writes what is still queued
    got = list(iter_raw(tmp_path / 'bag'))
    assert got == [(name, type_name, data, stamp) for name, type_name, data, stamp in sent]


def test_a_refused_write_ends_the_recording_once_and_nothing_is_queued_after_it(node, tmp_path):
    reasons = []
    bag = BagWriter(tmp_path / 'bag', chunk_size=2048, compression='none',
                    opener=lambda p: _Quota(p, 20_000))
    recording = Recording(node, bag, on_failure=reasons.append)
    sent = messages(2000)
    for i in range(0, len(sent), 100):   # a drain every 50 samples
        for name, type_name, data, stamp in sent[i:i + 100]:
            recording.write(name, type_name, QOS, data, stamp)
        recording.drain()
    assert len(reasons) == 1 and os.strerror(errno.ENOSPC) in reasons[0]
    assert recording.error == reasons[0] and bag.closed
    kept = recording.message_count
    for name, type_name, data, stamp in sent[:10]:
        recording.write(name, type_name, QOS, data, stamp)
    recording.drain()
    assert recording.message_count == kept
    assert recording.finish() == ''
    got = list(iter_raw(tmp_path / 'bag'))   # readable: a prefix of what was sent
    assert 0 < len(got) < len(sent)
    assert got == [(name, type_name, data, stamp) for name, type_name, data, stamp
                   in sent[:len(got)]]

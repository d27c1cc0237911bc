"""Every message the recorder loses is counted: recorded + lost = published.

A best-effort publisher sends a burst far faster than a recorder with a queue of one can
write; the bag's metadata (``custom_data``: ``abb_ros.lost_messages``) must account for every
message after the first one recorded, and the recorder's log says how many were lost.
"""

import json
import signal
import time

import pytest
import yaml
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64
from test_recorder import Publisher, finish, start_recorder

from abb_ros.io.bag.reader import read_bag
from abb_ros.nodes.recorder.recording import LossCounter

pytestmark = pytest.mark.ros

BURST = 5000


def test_gaps_in_the_publication_sequence_are_losses_and_a_restart_is_not():
    c = LossCounter()
    for seq in (5, 6, 9, 10, 14):
        c.see(seq)
    assert c.lost == 2 + 3
    c.see(1)       # a new publisher starts over: nothing lost
    c.see(2)
    c.see(0)       # sequence numbers unsupported by the middleware: ignored
    assert c.lost == 5


@pytest.mark.slow
def test_a_recorder_that_cannot_keep_up_reports_every_lost_message_in_the_bag(tmp_path):
    bag = tmp_path / 'bag'
    proc = start_recorder(bag, 'queue_depth:=1', 'topics:=["spindle/speed_cmd"]')
    pub = Publisher([])
    pub.pubs['spindle/speed_cmd'] = pub.node.create_publisher(
        Float64, 'spindle/speed_cmd',
        QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
    try:
        pub.wait_for_recorder()
        time.sleep(1.0)   # the recorder's subscription is matched and idle
        for i in range(BURST):
            pub.pubs['spindle/speed_cmd'].publish(Float64(data=float(i)))
        time.sleep(1.0)
        pub.pubs['spindle/speed_cmd'].publish(Float64(data=float(BURST)))  # seen: no tail
        time.sleep(1.0)
    finally:
        pub.close()
        code, out = finish(proc, signal.SIGINT)
    assert code == 0, out
    values = [m.data for _, m, _ in read_bag(bag)]
    assert values[-1] == float(BURST)
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    lost = json.loads(meta['custom_data']['abb_ros.lost_messages'])['/spindle/speed_cmd']
    # Sequence numbers count from the first message published (value 0 = sequence 1).
    assert len(values) + lost == BURST + 1 - int(values[0]), (len(values), lost, values[0])
    assert lost > 0, 'the burst was recorded whole: this test did not exercise a loss'
    assert f'{lost} message(s) lost' in out

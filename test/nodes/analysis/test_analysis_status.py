"""The analysis node encodes its status once per distinct verdict and restamps it.

At a steady speed the status and the margin are the same from one 50 Hz publication to the
next but for the header stamp: the node keeps their bytes and patches the stamp in. These
tests hold the patched bytes to the full encoding at that stamp, and the reuse to inputs that
did not change.
"""

import time

import pytest
import rclpy

from abb_ros.io.wire import cdr
from abb_ros.nodes.analysis.node import AnalysisNode, restamped

pytestmark = pytest.mark.ros

OMEGA = 811.0   # P3 of Table 1 [rad/s]


@pytest.fixture
def node():
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    made = AnalysisNode(context=ctx)
    try:
        deadline = time.monotonic() + 120
        while made.worker.table is None or made.worker.busy:
            assert time.monotonic() < deadline, 'timed out after 120 s waiting for the table'
            time.sleep(0.05)
        yield made
    finally:
        made.destroy_node()
        rclpy.shutdown(context=ctx)


def full_encoding(node, stamp_ns):
    """The status bytes encoded from scratch, as the node encoded every status before."""
    a = node.assessment()
    return cdr.diagnostics(stamp_ns, f'{node.get_fully_qualified_name()}: stability',
                           bytes([a.level]), a.message,
                           dict(a.values, parameters_from=node.parameters_from))


@pytest.mark.parametrize('stamp_ns', [0, 999_999_999, 1_000_000_000,
                                      1_796_314_960_800_562_448])
def test_a_restamped_status_equals_the_status_encoded_at_that_stamp(stamp_ns):
    values = {'omega': OMEGA, 'margin': 0.1039, 'source': 'table (interpolated)', 'n': 2}
    args = ('/ns/abb_analysis: stability', b'\x00', 'balanced and stable', values)
    assert restamped(cdr.diagnostics(12_345, *args), stamp_ns) == cdr.diagnostics(stamp_ns,
                                                                                  *args)


def test_a_status_at_an_unchanged_speed_is_encoded_once_and_a_new_speed_again(node):
    node.speed = (OMEGA, 5_000_000_000)
    node.publish_status()
    first = node._status
    assert restamped(first[1], 5_000_000_000) == full_encoding(node, 5_000_000_000)
    node.speed = (OMEGA, 6_000_000_123)    # the next joint_states: same speed, new stamp
    node.publish_status()
    assert node._status is first
    node.speed = (OMEGA + 1.0, 7_000_000_000)
    node.publish_status()
    assert node._status is not first
    assert restamped(node._status[1], 7_000_000_000) == full_encoding(node, 7_000_000_000)
    assert node._status[0] == cdr.float64(0, 0, node.assessment().margin)

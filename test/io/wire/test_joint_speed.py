"""The analysis node's one-field JointState reader agrees with rclpy's deserialisation."""

import math

import pytest
from builtin_interfaces.msg import Time
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState

from abb_ros.io.wire import cdr
from abb_ros.io.wire.joint_speed import JointSpeedReader


def message(names, velocity, position=None, frame='', sec=12, nanosec=345_000_000):
    msg = JointState(name=names, velocity=velocity,
                     position=list(range(len(names))) if position is None else position)
    msg.header.stamp = Time(sec=sec, nanosec=nanosec)
    msg.header.frame_id = frame
    return serialize_message(msg)


@pytest.mark.parametrize('names, velocity, omega, n', [
    (['spindle', 'ball_1', 'ball_2'], [376.5, 1.0, 2.0], 376.5, 2),
    (['ball_1', 'spindle', 'ball_2'], [1.0, 99.0, 2.0], 99.0, 2),
    (['spindle'] + [f'ball_{i}' for i in range(1, 11)], [5.0] + [0.5] * 10, 5.0, 10),
    (['wheel'], [7.25], 7.25, 0),
    ([], [3.5], 3.5, 0),
])
def test_spindle_speed_ball_count_and_stamp_are_those_of_the_message(names, velocity, omega,
                                                                       n):
    js = JointSpeedReader()(message(names, velocity))
    assert (js.omega, js.n, js.named) == (omega, n, bool(names))
    assert js.stamp_ns == 12_345_000_000


def test_a_message_without_velocities_has_no_speed():
    assert math.isnan(JointSpeedReader()(message(['spindle', 'ball_1'], [])).omega)


def test_the_cached_layout_follows_a_change_of_names_frame_or_position_count():
    read = JointSpeedReader()
    assert read(message(['spindle', 'ball_1'], [1.0, 2.0])).omega == 1.0
    assert read(message(['ball_1', 'spindle'], [1.0, 2.0])).omega == 2.0
    assert read(message(['ball_1', 'spindle'], [1.0, 2.0], frame='base_link')).omega == 2.0
    assert read(message(['ball_1', 'spindle'], [1.0, 3.0], position=[])).omega == 3.0
    assert read(message(['spindle', 'ball_1', 'ball_2'], [4.0, 0, 0])).n == 2


def test_the_simulators_own_encoding_reads_back_exactly():
    for effort in ([], [0.002, 0.0, 0.0, 0.0]):     # speed mode; torque mode (effort[0])
        content = (3, [0.1, 0.2, 0.3, 0.4], [376.99111843077515, -1.5, 2.5, 0.25], effort)
        data = cdr.joint_state(7, 5_000, content)
        js = JointSpeedReader()(data)
        assert (js.omega, js.n, js.stamp_ns) == (376.99111843077515, 3, 7_000_005_000)


@pytest.mark.parametrize('cut', [3, 10, 20, 40])
def test_truncated_bytes_are_refused_with_value_error(cut):
    data = message(['spindle', 'ball_1'], [1.0, 2.0])
    with pytest.raises(ValueError):
        JointSpeedReader()(data[:cut])

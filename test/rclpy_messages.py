"""Reference rclpy messages of a simulation sample, filled field by field from its contents.

The package publishes and records CDR bytes encoded straight from the message contents
(:func:`abb_ros.io.wire.ros_messages.sample_contents`, :mod:`abb_ros.io.wire.cdr`) and builds no
rclpy message. test_cdr checks those bytes against these messages, serialised by an independent
encoder (cdr_reference.cdr_bytes).
"""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from abb_ros.io.wire.ros_messages import (
    TOPIC_FRAMES,
    TOPIC_TYPES,
    diagnostics_content,
    joint_names,
    sample_contents,
    time_msg,
)
from abb_ros.io.wire.topics import SPINDLE_SPEED


def _joint_state(msg, stamp, content):
    n, position, velocity, effort = content
    msg.header.stamp = stamp
    msg.name = joint_names(n)
    msg.position, msg.velocity, msg.effort = position, velocity, effort
    return msg


def _pose(msg, stamp, content):
    msg.header.stamp = stamp
    msg.header.frame_id = TOPIC_FRAMES['deck/pose']
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z, o.x, o.y, o.z, o.w = content
    return msg


def _twist(msg, stamp, content):
    msg.header.stamp = stamp
    msg.header.frame_id = TOPIC_FRAMES['deck/twist']
    v, w = msg.twist.linear, msg.twist.angular
    v.x, v.y, v.z, w.x, w.y, w.z = content
    return msg


def _imu(msg, stamp, content):
    msg.header.stamp = stamp
    msg.header.frame_id = TOPIC_FRAMES['deck/imu']
    msg.orientation_covariance[0] = -1.0
    w, a = msg.angular_velocity, msg.linear_acceleration
    w.x, w.y, w.z, a.x, a.y, a.z, accel_variance, gyro_variance = content
    for i in (0, 4, 8):
        msg.linear_acceleration_covariance[i] = accel_variance
        msg.angular_velocity_covariance[i] = gyro_variance
    return msg


def _clock(msg, stamp, _content):
    msg.clock = stamp
    return msg


def _float64(msg, _stamp, content):
    msg.data = content
    return msg


_FILL = {'joint_states': _joint_state, 'deck/pose': _pose, 'deck/twist': _twist,
         'deck/imu': _imu, '/clock': _clock, SPINDLE_SPEED: _float64}


def sample_messages(sample, dt_ns: int, imu_config, epoch_ns: int = 0,
                    with_clock: bool = False) -> list[tuple[str, object]]:
    """Build the (topic, rclpy message) pairs of one sample, in publishing order."""
    stamp_ns, contents = sample_contents(sample, dt_ns, imu_config, epoch_ns, with_clock)
    stamp = time_msg(stamp_ns)
    return [(topic, _FILL[topic](TOPIC_TYPES[topic](), stamp, content))
            for topic, content in contents]


def diagnostics(stamp_ns: int, name: str, level: bytes, message: str,
                values: dict) -> DiagnosticArray:
    """Build the DiagnosticArray of one status with ``values`` as key/value text."""
    level, name, message, hardware_id, pairs = diagnostics_content(name, level, message,
                                                                   values)
    status = DiagnosticStatus(level=level, name=name, message=message,
                              hardware_id=hardware_id)
    status.values = [KeyValue(key=k, value=v) for k, v in pairs]
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = time_msg(stamp_ns)
    return msg

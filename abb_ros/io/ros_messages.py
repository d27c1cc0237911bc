"""The ROS messages of every simulator topic, built from a simulation sample.

The live node (:mod:`abb_ros.nodes.simulator`) and the headless ``abb-sim run`` call the
same functions, so live and headless bags are message for message identical. Only the
message packages are imported (no rclpy, no DDS). Topics and frames are those of
design.md; all values SI (m, rad, s).
"""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import (Point, Pose, PoseStamped, Quaternion, Twist, TwistStamped,
                               Vector3)
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import Header

from abb_ros.model.dynamics import n_coords
from abb_ros.model.sampling import Sample
from abb_ros.model.sensors import ImuConfig, deck_velocity, euler_quaternion

__all__ = ['FRAME_BASE', 'FRAME_DECK', 'TOPIC_TYPES', 'STATE_TOPICS', 'time_msg',
           'joint_names', 'joint_state', 'deck_pose', 'deck_twist', 'deck_imu', 'clock',
           'diagnostics', 'sample_messages']

FRAME_BASE = 'base'
FRAME_DECK = 'deck'

TOPIC_TYPES = {
    'joint_states': JointState,
    'deck/pose': PoseStamped,
    'deck/twist': TwistStamped,
    'deck/imu': Imu,
    '/clock': Clock,
    '/diagnostics': DiagnosticArray,
}
"""Every topic the simulator publishes (relative names resolve in the node's namespace)."""

STATE_TOPICS = ('joint_states', 'deck/pose', 'deck/twist')
"""Topics published at ``publish_rate_hz`` from the state; ``deck/imu`` has its own rate."""


def time_msg(stamp_ns: int) -> Time:
    """builtin_interfaces/Time of an integer nanosecond stamp (exact)."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def joint_names(n: int) -> list[str]:
    """``spindle``, ``ball_1``..``ball_n``."""
    return ['spindle'] + [f'ball_{i + 1}' for i in range(n)]


def _header(stamp, frame_id: str = '') -> Header:
    """Header of a stamp given as integer nanoseconds or a Time message."""
    return Header(stamp=stamp if isinstance(stamp, Time) else time_msg(stamp),
                  frame_id=frame_id)


def joint_state(stamp_ns, y: np.ndarray, n: int) -> JointState:
    """Spindle angle theta and speed omega; ball angles phi_i and rates phi_i' [rad, rad/s]."""
    N = n_coords(n)
    idx = [0] + list(range(7, N))
    return JointState(header=_header(stamp_ns), name=joint_names(n),
                      position=[float(y[i]) for i in idx],
                      velocity=[float(y[N + i]) for i in idx])


def deck_pose(stamp_ns, y: np.ndarray) -> PoseStamped:
    """Position of C (X, Y, Z) [m] and the deck orientation R = Rz(gamma) Rx(alpha) Ry(beta)
    in frame ``base``."""
    x, y_, z, w = euler_quaternion(float(y[4]), float(y[5]), float(y[6]))
    return PoseStamped(header=_header(stamp_ns, FRAME_BASE), pose=Pose(
        position=Point(x=float(y[1]), y=float(y[2]), z=float(y[3])),
        orientation=Quaternion(x=x, y=y_, z=z, w=w)))


def _vector3(v) -> Vector3:
    return Vector3(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def deck_twist(stamp_ns, y: np.ndarray, n: int) -> TwistStamped:
    """Velocity of C [m/s] and angular velocity Eq. (10) [rad/s], both in deck axes."""
    N = n_coords(n)
    v, w = deck_velocity(y[:N], y[N:])
    return TwistStamped(header=_header(stamp_ns, FRAME_DECK),
                        twist=Twist(linear=_vector3(v), angular=_vector3(w)))


def deck_imu(stamp_ns, reading, config: ImuConfig) -> Imu:
    """Specific force [m/s^2] and angular rate [rad/s] in frame ``deck``; no orientation
    (orientation_covariance[0] = -1); diagonal covariances = noise density^2 * rate."""
    a, g = config.accel_variance, config.gyro_variance
    return Imu(header=_header(stamp_ns, FRAME_DECK),
               orientation_covariance=_NO_ORIENTATION,
               linear_acceleration=_vector3(reading.accel),
               linear_acceleration_covariance=[a, 0.0, 0.0, 0.0, a, 0.0, 0.0, 0.0, a],
               angular_velocity=_vector3(reading.gyro),
               angular_velocity_covariance=[g, 0.0, 0.0, 0.0, g, 0.0, 0.0, 0.0, g])


_NO_ORIENTATION = [-1.0] + [0.0] * 8


def clock(stamp_ns) -> Clock:
    """/clock at a stamp (integer nanoseconds or a Time message)."""
    return Clock(clock=stamp_ns if isinstance(stamp_ns, Time) else time_msg(stamp_ns))


def diagnostics(stamp_ns: int, name: str, level: bytes, message: str,
                values: dict) -> DiagnosticArray:
    """One DiagnosticStatus (``level`` DiagnosticStatus.OK/WARN/ERROR) with ``values`` as
    key/value text (floats with repr precision)."""
    status = DiagnosticStatus(level=level, name=name, message=message,
                              hardware_id='abb_ros')
    status.values = [KeyValue(key=k, value=_text(v)) for k, v in values.items()]
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = time_msg(stamp_ns)
    return msg


def _text(value) -> str:
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    return str(value)


def sample_messages(sample: Sample, dt_ns: int, imu_config: ImuConfig, epoch_ns: int = 0,
                    with_clock: bool = False) -> list[tuple[str, object]]:
    """(topic, message) pairs of one :class:`Sample`, in publishing order: ``/clock``
    first (when the simulator owns time), then the state topics, then ``deck/imu``."""
    stamp = time_msg(sample.stamp_ns(dt_ns, epoch_ns))
    out = []
    if with_clock:
        out.append(('/clock', clock(stamp)))
    if sample.y is not None:
        out += [('joint_states', joint_state(stamp, sample.y, sample.n)),
                ('deck/pose', deck_pose(stamp, sample.y)),
                ('deck/twist', deck_twist(stamp, sample.y, sample.n))]
    if sample.imu is not None:
        out.append(('deck/imu', deck_imu(stamp, sample.imu, imu_config)))
    return out

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
from geometry_msgs.msg import PoseStamped, TwistStamped
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

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


def _stamp(stamp) -> Time:
    return stamp if isinstance(stamp, Time) else time_msg(stamp)


# Every builder below fills ``out`` in place when given (the live node reuses one message
# per topic: the generated constructors build every nested default, which costs more than
# the physics at 1 kHz); without ``out`` it returns a new message. ``stamp`` is integer
# nanoseconds or a builtin_interfaces/Time.

def joint_state(stamp, y: np.ndarray, n: int, out: JointState | None = None) -> JointState:
    """Spindle angle theta and speed omega; ball angles phi_i and rates phi_i' [rad, rad/s]."""
    msg = JointState() if out is None else out
    N = n_coords(n)
    msg.header.stamp = _stamp(stamp)
    if len(msg.name) != n + 1:
        msg.name = joint_names(n)
    msg.position = [float(y[0])] + y[7:N].tolist()
    msg.velocity = [float(y[N])] + y[N + 7:].tolist()
    return msg


def deck_pose(stamp, y: np.ndarray, out: PoseStamped | None = None) -> PoseStamped:
    """Position of C (X, Y, Z) [m] and the deck orientation R = Rz(gamma) Rx(alpha) Ry(beta)
    in frame ``base``."""
    msg = PoseStamped() if out is None else out
    msg.header.stamp = _stamp(stamp)
    msg.header.frame_id = FRAME_BASE
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = float(y[1]), float(y[2]), float(y[3])
    o.x, o.y, o.z, o.w = euler_quaternion(float(y[4]), float(y[5]), float(y[6]))
    return msg


def _set3(vec, values) -> None:
    vec.x, vec.y, vec.z = float(values[0]), float(values[1]), float(values[2])


def deck_twist(stamp, y: np.ndarray, n: int, out: TwistStamped | None = None
               ) -> TwistStamped:
    """Velocity of C [m/s] and angular velocity Eq. (10) [rad/s], both in deck axes."""
    msg = TwistStamped() if out is None else out
    N = n_coords(n)
    v, w = deck_velocity(y[:N], y[N:])
    msg.header.stamp = _stamp(stamp)
    msg.header.frame_id = FRAME_DECK
    _set3(msg.twist.linear, v)
    _set3(msg.twist.angular, w)
    return msg


def deck_imu(stamp, reading, config: ImuConfig, out: Imu | None = None) -> Imu:
    """Specific force [m/s^2] and angular rate [rad/s] in frame ``deck``; no orientation
    (orientation_covariance[0] = -1); diagonal covariances = noise density^2 * rate."""
    msg = Imu() if out is None else out
    msg.header.stamp = _stamp(stamp)
    msg.header.frame_id = FRAME_DECK
    msg.orientation_covariance[0] = -1.0
    _set3(msg.linear_acceleration, reading.accel)
    _set3(msg.angular_velocity, reading.gyro)
    for i in (0, 4, 8):
        msg.linear_acceleration_covariance[i] = config.accel_variance
        msg.angular_velocity_covariance[i] = config.gyro_variance
    return msg


def clock(stamp, out: Clock | None = None) -> Clock:
    """/clock at a stamp."""
    msg = Clock() if out is None else out
    msg.clock = _stamp(stamp)
    return msg


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
                    with_clock: bool = False, reuse: dict | None = None
                    ) -> list[tuple[str, object]]:
    """(topic, message) pairs of one :class:`Sample`, in publishing order: ``/clock``
    first (when the simulator owns time), then the state topics, then ``deck/imu``.

    ``reuse``: {topic: message} filled in place (publish them before the next call)."""
    stamp = time_msg(sample.stamp_ns(dt_ns, epoch_ns))
    get = (reuse or {}).get
    out = []
    if with_clock:
        out.append(('/clock', clock(stamp, get('/clock'))))
    if sample.y is not None:
        out += [('joint_states', joint_state(stamp, sample.y, sample.n, get('joint_states'))),
                ('deck/pose', deck_pose(stamp, sample.y, get('deck/pose'))),
                ('deck/twist', deck_twist(stamp, sample.y, sample.n, get('deck/twist')))]
    if sample.imu is not None:
        out.append(('deck/imu', deck_imu(stamp, sample.imu, imu_config, get('deck/imu'))))
    return out

"""The ROS messages of every simulator topic, built from a simulation sample.

What a message holds is defined once, as plain values (``*_content``, :func:`sample_contents`);
the live node (:mod:`abb_ros.nodes.simulator`) fills rclpy messages with them
(:func:`sample_messages`) and the headless ``abb-sim run`` encodes them straight to CDR bytes
(:mod:`abb_ros.io.cdr`, byte-identical to the serialised messages), so live and headless bags
are message for message identical. Only the message packages are imported (no rclpy, no
DDS). Topics, types and frames come from :mod:`abb_ros.io.topics`; all values SI (m, rad, s).
"""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped, TwistStamped
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import Float64

from abb_ros.io import topics
from abb_ros.io.topics import FRAME_BASE, FRAME_DECK
from abb_ros.model import sensors
from abb_ros.model.sampling import Sample
from abb_ros.model.sensors import ImuConfig
from abb_ros.model.state import PHI, StateLayout

__all__ = ['FRAME_BASE', 'FRAME_DECK', 'TOPIC_TYPES', 'STATE_TOPICS', 'time_msg',
           'joint_names', 'joint_state', 'deck_pose', 'deck_twist', 'deck_imu', 'clock',
           'diagnostics', 'sample_messages', 'TOPIC_FRAMES', 'joint_state_content',
           'deck_pose_twist_content', 'deck_imu_content', 'diagnostics_content',
           'sample_contents', 'SPEED_TOPIC']

HARDWARE_ID = 'abb_ros'

TOPIC_TYPES = {t.name: topics.message_class(t.type) for t in topics.published_by('simulator')}
"""Every topic the simulator publishes -> message class (:data:`abb_ros.io.topics.TOPICS`)."""

STATE_TOPICS = tuple(t.name for t in topics.TOPICS if t.rate == topics.STATE)

SPEED_TOPIC = 'spindle/speed'
"""The FG's measured speed [rad/s] (std_msgs/Float64, no stamp), with the state topics."""
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


# ---- contents ------------------------------------------------------------------------------
# What each message holds, as plain floats: the one definition that both the rclpy messages
# below (live node) and the CDR encoder abb_ros.io.cdr (headless bags) are made from. Names
# and frames are fixed per topic (joint_names, TOPIC_FRAMES).

TOPIC_FRAMES = {t.name: t.frame for t in topics.TOPICS if t.frame is not None}
"""header.frame_id of each stamped topic."""


def joint_state_content(y: np.ndarray, n: int) -> tuple[list[float], list[float]]:
    """(position, velocity) of ``joint_names(n)``: [theta, phi_1..phi_n] [rad] and
    [omega, phi_1'..phi_n'] [rad/s]."""
    s = StateLayout.of(n)
    v = y.tolist()
    return ([v[s.theta_index]] + v[s.phi_slice], [v[s.omega_index]] + v[s.phi_rate_slice])


def deck_pose_twist_content(y: np.ndarray, n: int) -> tuple[tuple[float, ...],
                                                           tuple[float, ...]]:
    """((X, Y, Z, qx, qy, qz, qw), (vx, vy, vz, wx, wy, wz)): C in ``base`` [m] and
    R = Rz(gamma) Rx(alpha) Ry(beta); the velocity of C [m/s] and Eq. (10) [rad/s], deck
    axes (one compiled kernel, :func:`abb_ros.model.sensors.deck_pose_twist`)."""
    out = np.empty(13)
    sensors.JIT.deck_pose_twist(y, n, out)
    v = out.tolist()
    return tuple(v[:7]), tuple(v[7:])


def deck_imu_content(reading, config: ImuConfig) -> tuple[float, ...]:
    """(wx, wy, wz, ax, ay, az, accel_variance, gyro_variance): angular rate [rad/s] and
    specific force [m/s^2] in deck axes, and the diagonal of their covariances."""
    return (tuple(reading.gyro.tolist()) + tuple(reading.accel.tolist())
            + (config.accel_variance, config.gyro_variance))


def sample_contents(sample: Sample, dt_ns: int, imu_config: ImuConfig, epoch_ns: int = 0,
                    with_clock: bool = False) -> tuple[int, list[tuple[str, object]]]:
    """(stamp [ns], [(topic, content)]) of one :class:`Sample`, in publishing order:
    ``/clock`` first (when the simulator owns time; content None), then the state topics,
    then ``spindle/speed`` (when the sample has a speed reading), then ``deck/imu``.
    ``joint_states`` content is (n, position, velocity, effort), effort [] in speed mode,
    else [motor torque, 0 (balls)...] [N m]."""
    out = [('/clock', None)] if with_clock else []
    y = sample.y
    if y is not None:
        effort = [] if sample.effort is None else [sample.effort] + [0.0] * sample.n
        pose, twist = deck_pose_twist_content(y, sample.n)
        out += [('joint_states', (sample.n,) + joint_state_content(y, sample.n) + (effort,)),
                ('deck/pose', pose), ('deck/twist', twist)]
    if sample.speed is not None:
        out.append((SPEED_TOPIC, sample.speed))
    if sample.imu is not None:
        out.append(('deck/imu', deck_imu_content(sample.imu, imu_config)))
    return sample.stamp_ns(dt_ns, epoch_ns), out


# ---- rclpy messages ------------------------------------------------------------------------
# Every builder fills ``out`` in place when given (the live node reuses one message per topic:
# the generated constructors build every nested default, which costs more than the physics at
# 1 kHz); without ``out`` it returns a new message. ``stamp`` is integer nanoseconds or a
# builtin_interfaces/Time.

def _fill_joint_state(msg: JointState, stamp: Time, content) -> JointState:
    n, position, velocity, effort = content
    msg.header.stamp = stamp
    if len(msg.name) != n + 1:
        msg.name = joint_names(n)
    msg.position = position
    msg.velocity = velocity
    msg.effort = effort
    return msg


def _fill_pose(msg: PoseStamped, stamp: Time, content) -> PoseStamped:
    msg.header.stamp = stamp
    msg.header.frame_id = TOPIC_FRAMES['deck/pose']
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z, o.x, o.y, o.z, o.w = content
    return msg


def _fill_twist(msg: TwistStamped, stamp: Time, content) -> TwistStamped:
    msg.header.stamp = stamp
    msg.header.frame_id = TOPIC_FRAMES['deck/twist']
    v, w = msg.twist.linear, msg.twist.angular
    v.x, v.y, v.z, w.x, w.y, w.z = content
    return msg


def _fill_imu(msg: Imu, stamp: Time, content) -> Imu:
    msg.header.stamp = stamp
    msg.header.frame_id = TOPIC_FRAMES['deck/imu']
    msg.orientation_covariance[0] = -1.0
    w, a = msg.angular_velocity, msg.linear_acceleration
    w.x, w.y, w.z, a.x, a.y, a.z, accel_variance, gyro_variance = content
    for i in (0, 4, 8):
        msg.linear_acceleration_covariance[i] = accel_variance
        msg.angular_velocity_covariance[i] = gyro_variance
    return msg


def _fill_clock(msg: Clock, stamp: Time, content=None) -> Clock:
    msg.clock = stamp
    return msg


def _fill_float64(msg: Float64, stamp: Time, content: float) -> Float64:
    msg.data = content
    return msg


_FILL = {'joint_states': _fill_joint_state, 'deck/pose': _fill_pose,
         'deck/twist': _fill_twist, 'deck/imu': _fill_imu, '/clock': _fill_clock,
         SPEED_TOPIC: _fill_float64}


def joint_state(stamp, y: np.ndarray, n: int, out: JointState | None = None) -> JointState:
    """Spindle angle theta and speed omega; ball angles phi_i and rates phi_i' [rad, rad/s]."""
    return _fill_joint_state(JointState() if out is None else out, _stamp(stamp),
                             (n,) + joint_state_content(y, n) + ([],))


def deck_pose(stamp, y: np.ndarray, out: PoseStamped | None = None) -> PoseStamped:
    """Position of C (X, Y, Z) [m] and the deck orientation R = Rz(gamma) Rx(alpha) Ry(beta)
    in frame ``base``."""
    return _fill_pose(PoseStamped() if out is None else out, _stamp(stamp),
                      deck_pose_twist_content(y, len(y) // 2 - PHI)[0])


def deck_twist(stamp, y: np.ndarray, n: int, out: TwistStamped | None = None
               ) -> TwistStamped:
    """Velocity of C [m/s] and angular velocity Eq. (10) [rad/s], both in deck axes."""
    return _fill_twist(TwistStamped() if out is None else out, _stamp(stamp),
                       deck_pose_twist_content(y, n)[1])


def deck_imu(stamp, reading, config: ImuConfig, out: Imu | None = None) -> Imu:
    """Specific force [m/s^2] and angular rate [rad/s] in frame ``deck``; no orientation
    (orientation_covariance[0] = -1); diagonal covariances = noise density^2 * rate."""
    return _fill_imu(Imu() if out is None else out, _stamp(stamp),
                     deck_imu_content(reading, config))


def clock(stamp, out: Clock | None = None) -> Clock:
    """/clock at a stamp."""
    return _fill_clock(Clock() if out is None else out, _stamp(stamp))


def diagnostics_content(name: str, level: bytes, message: str, values: dict
                        ) -> tuple[bytes, str, str, str, list[tuple[str, str]]]:
    """(level, name, message, hardware_id, [(key, value text)]) of the one DiagnosticStatus
    (floats as repr text)."""
    return level, name, message, HARDWARE_ID, [(k, _text(v)) for k, v in values.items()]


def diagnostics(stamp_ns: int, name: str, level: bytes, message: str,
                values: dict) -> DiagnosticArray:
    """One DiagnosticStatus (``level`` DiagnosticStatus.OK/WARN/ERROR) with ``values`` as
    key/value text (floats with repr precision)."""
    level, name, message, hardware_id, pairs = diagnostics_content(name, level, message,
                                                                   values)
    status = DiagnosticStatus(level=level, name=name, message=message,
                              hardware_id=hardware_id)
    status.values = [KeyValue(key=k, value=v) for k, v in pairs]
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
    """(topic, message) pairs of one :class:`Sample`, in publishing order (see
    :func:`sample_contents`).

    ``reuse``: {topic: message} filled in place (publish them before the next call)."""
    stamp_ns, contents = sample_contents(sample, dt_ns, imu_config, epoch_ns, with_clock)
    stamp = time_msg(stamp_ns)
    get = (reuse or {}).get
    out = []
    for topic, content in contents:
        msg = get(topic)
        out.append((topic, _FILL[topic](TOPIC_TYPES[topic]() if msg is None else msg, stamp,
                                        content)))
    return out

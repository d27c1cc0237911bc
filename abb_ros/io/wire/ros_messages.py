"""The ROS messages of every simulator topic, as plain values from a simulation sample.

What a message holds is defined once, as plain values (``*_content``, :func:`sample_contents`);
:mod:`abb_ros.io.wire.cdr` encodes them straight to CDR bytes for the live node
(:mod:`abb_ros.nodes.simulator`) and the headless ``abb-sim run`` alike, so live and headless
bags are message for message identical. Only the message packages are imported (no rclpy, no
DDS). Topics, types and frames come from :mod:`abb_ros.io.wire.topics`; all values SI (m, rad, s).
"""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time

from abb_ros.io.wire import topics
from abb_ros.io.wire.topics import (
    CLOCK_TOPIC,
    DECK_IMU,
    DECK_POSE,
    DECK_TWIST,
    FRAME_BASE,
    FRAME_DECK,
    JOINT_STATES,
    SPINDLE_SPEED,
)
from abb_ros.model.dynamics.state import StateLayout
from abb_ros.model.sensors import imu
from abb_ros.model.sensors.imu import ImuConfig
from abb_ros.model.sensors.sampling import Sample

__all__ = ['FRAME_BASE', 'FRAME_DECK', 'TOPIC_TYPES', 'STATE_TOPICS', 'time_msg',
           'joint_names', 'TOPIC_FRAMES', 'joint_state_content', 'deck_pose_twist_content',
           'deck_imu_content', 'diagnostics_content', 'sample_contents']

HARDWARE_ID = 'abb_ros'

TOPIC_TYPES = {t.name: topics.message_class(t.type) for t in topics.published_by('simulator')}
"""Every topic the simulator publishes -> message class (:data:`abb_ros.io.wire.topics.TOPICS`)."""

STATE_TOPICS = tuple(t.name for t in topics.TOPICS if t.rate == topics.STATE)
"""Topics published at ``publish_rate_hz`` from the state; ``deck/imu`` has its own rate."""


def time_msg(stamp_ns: int) -> Time:
    """Convert an integer nanosecond stamp to a builtin_interfaces/Time (exact)."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def joint_names(n: int) -> list[str]:
    """Name the joints of ``n`` balls: ``spindle``, ``ball_1``..``ball_n``."""
    return ['spindle'] + [f'ball_{i + 1}' for i in range(n)]


# ---- contents ------------------------------------------------------------------------------
# What each message holds, as plain floats: the one definition the CDR encoder abb_ros.io.wire.cdr
# encodes. Names and frames are fixed per topic (joint_names, TOPIC_FRAMES).

TOPIC_FRAMES = {t.name: t.frame for t in topics.TOPICS if t.frame is not None}
"""header.frame_id of each stamped topic."""


def joint_state_content(y: np.ndarray, n: int) -> tuple[list[float], list[float]]:
    """Return (position, velocity) of ``joint_names(n)`` from the state ``y``.

    [theta, phi_1..phi_n] [rad] and [omega, phi_1'..phi_n'] [rad/s].
    """
    s = StateLayout.of(n)
    v = y.tolist()
    return ([v[s.theta_index]] + v[s.phi_slice], [v[s.omega_index]] + v[s.phi_rate_slice])


def deck_pose_twist_content(y: np.ndarray, n: int) -> tuple[tuple[float, ...],
                                                           tuple[float, ...]]:
    """Return the deck's pose and twist: ((X, Y, Z, qx, qy, qz, qw), (vx, vy, vz, wx, wy, wz)).

    C in ``base`` [m] and R = Rz(gamma) Rx(alpha) Ry(beta); the velocity of C [m/s] and
    Eq. (10) [rad/s], deck axes (one compiled kernel,
    :func:`abb_ros.model.sensors.imu.deck_pose_twist`).
    """
    out = np.empty(13)
    imu.JIT.deck_pose_twist(y, n, out)
    v = out.tolist()
    return tuple(v[:7]), tuple(v[7:])


def deck_imu_content(reading, config: ImuConfig) -> tuple[float, ...]:
    """Return (wx, wy, wz, ax, ay, az, accel_variance, gyro_variance) of an IMU reading.

    Angular rate [rad/s] and specific force [m/s^2] in deck axes, and the diagonal of their
    covariances.
    """
    return (tuple(reading.gyro.tolist()) + tuple(reading.accel.tolist())
            + (config.accel_variance, config.gyro_variance))


def sample_contents(sample: Sample, dt_ns: int, imu_config: ImuConfig, epoch_ns: int = 0,
                    with_clock: bool = False) -> tuple[int, list[tuple[str, object]]]:
    """Return (stamp [ns], [(topic, content)]) of one :class:`Sample`, in publishing order.

    ``/clock`` first (when the simulator publishes it; content None), then the state topics,
    then ``spindle/speed`` (when the sample has a speed reading), then ``deck/imu``.
    ``joint_states`` content is (n, position, velocity, effort), effort [] in speed mode,
    else [motor torque, 0 (balls)...] [N m].
    """
    out = [(CLOCK_TOPIC, None)] if with_clock else []
    y = sample.y
    if y is not None:
        effort = [] if sample.effort is None else [sample.effort] + [0.0] * sample.n
        pose, twist = deck_pose_twist_content(y, sample.n)
        out += [(JOINT_STATES, (sample.n,) + joint_state_content(y, sample.n) + (effort,)),
                (DECK_POSE, pose), (DECK_TWIST, twist)]
    if sample.speed is not None:
        out.append((SPINDLE_SPEED, sample.speed))
    if sample.imu is not None:
        out.append((DECK_IMU, deck_imu_content(sample.imu, imu_config)))
    return sample.stamp_ns(dt_ns, epoch_ns), out


def diagnostics_content(name: str, level: bytes, message: str, values: dict
                        ) -> tuple[bytes, str, str, str, list[tuple[str, str]]]:
    """Return (level, name, message, hardware_id, [(key, value text)]) of one status.

    The contents of the one DiagnosticStatus of a DiagnosticArray; floats as repr text.
    """
    return level, name, message, HARDWARE_ID, [(k, _text(v)) for k, v in values.items()]


def _text(value) -> str:
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    return str(value)

"""Deck kinematics and the IMU model (accelerometer + gyro on the feeding deck).

Pure numpy, no rclpy. Frames as in docs/ros_api.md: ``base`` is the inertial XYZ of the paper,
``deck`` the deck body frame xyz with origin at C. The Euler sequence of Eqs. (1)-(2),
``x = T_beta T_alpha T_gamma X``, makes the deck-to-base rotation

    R = (T_beta T_alpha T_gamma)^T = Rz(gamma) Rx(alpha) Ry(beta)

(each R* an active right-handed rotation). The deck's angular velocity in deck axes is
Eq. (10); its time derivative (deck axes, equal in both frames since w x w = 0) is
:func:`deck_angular_acceleration`.

An IMU mounted at ``r`` (deck axes, from C) measures

    specific force  f = a_C + w' x r + w x (w x r) - g      (all in deck axes)
    angular rate    w                                          (Eq. 10)

with a_C the inertial acceleration of C and g gravity (off by default, as in the paper,
which neglects it). Each channel adds white noise of density ``*_noise_density``
(discrete standard deviation density * sqrt(rate)) and a bias that starts at a draw of
standard deviation ``*_bias`` and random-walks with density ``*_bias_random_walk``
(increment standard deviation rw * sqrt(1 / rate)). The noise comes from a numpy
Generator seeded with ``seed``: same seed, same readings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from abb_ros.model.dynamics.state import ALPHA, DECK, PHI
from abb_ros.model.jit import KernelSet
from abb_ros.model.sensors.normals import NormalStream

__all__ = ['GRAVITY', 'euler_rotation', 'euler_quaternion', 'deck_angular_velocity',
           'deck_angular_acceleration', 'point_specific_force', 'ImuConfig', 'ImuReading',
           'ImuModel', 'deck_velocity']

GRAVITY = 9.80665
"""Standard gravity [m/s^2], acting along -Z of the base frame when enabled."""

kernel = KernelSet()


@kernel
def _t_matrix(alpha: float, beta: float, gamma: float) -> tuple[float, ...]:
    """Return T_beta T_alpha T_gamma of Eq. (2), row-major (9 floats): base -> deck components.

    Plain floats: at one call per sample, numpy's per-call overhead on 3 x 3 arrays costs
    more than the arithmetic.
    """
    ca, sa = math.cos(alpha), math.sin(alpha)
    cb, sb = math.cos(beta), math.sin(beta)
    cg, sg = math.cos(gamma), math.sin(gamma)
    # Rows are the deck axes i, j, k in base components (Eq. 6 with 'cos psi' = cos gamma).
    return (cb * cg - sa * sb * sg, cb * sg + sa * sb * cg, -ca * sb,
            -ca * sg, ca * cg, sa,
            sb * cg + sa * cb * sg, sb * sg - sa * cb * cg, ca * cb)


@kernel
def _mul(t, v) -> tuple[float, float, float]:
    return (t[0] * v[0] + t[1] * v[1] + t[2] * v[2],
            t[3] * v[0] + t[4] * v[1] + t[5] * v[2],
            t[6] * v[0] + t[7] * v[1] + t[8] * v[2])


@kernel
def _cross(u, v) -> tuple[float, float, float]:
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def euler_rotation(alpha: float, beta: float, gamma: float) -> np.ndarray:
    """Return the deck-to-base rotation R = Rz(gamma) Rx(alpha) Ry(beta), Eqs. (1)-(2).

    R = (T_beta T_alpha T_gamma)^T, shape (3, 3); ``R @ v_deck = v_base``.
    """
    return np.array(_t_matrix(alpha, beta, gamma)).reshape(3, 3).T


@kernel
def euler_quaternion(alpha: float, beta: float, gamma: float) -> tuple[float, float, float,
                                                                         float]:
    """Return the unit quaternion (x, y, z, w) of R = Rz(gamma) Rx(alpha) Ry(beta).

    The Hamilton product qz * qx * qy, in the order of geometry_msgs/Quaternion.
    """
    cg, sg = math.cos(gamma / 2), math.sin(gamma / 2)
    ca, sa = math.cos(alpha / 2), math.sin(alpha / 2)
    cb, sb = math.cos(beta / 2), math.sin(beta / 2)
    # qz * qx = (w, x, y, z) = (cg ca, cg sa, sg sa, sg ca); then * qy = (cb, 0, sb, 0).
    w0, x0, y0, z0 = cg * ca, cg * sa, sg * sa, sg * ca
    w = w0 * cb - y0 * sb
    x = x0 * cb - z0 * sb
    y = w0 * sb + y0 * cb
    z = z0 * cb + x0 * sb
    return x, y, z, w


@kernel
def _omega(alpha, beta, dalpha, dbeta, dgamma) -> tuple[float, float, float]:
    ca, sa = math.cos(alpha), math.sin(alpha)
    cb, sb = math.cos(beta), math.sin(beta)
    return (dalpha * cb - dgamma * ca * sb, dbeta + dgamma * sa, dalpha * sb + dgamma * ca * cb)


@kernel
def _omega_dot(alpha, beta, dalpha, dbeta, dgamma, ddalpha, ddbeta, ddgamma
               ) -> tuple[float, float, float]:
    ca, sa = math.cos(alpha), math.sin(alpha)
    cb, sb = math.cos(beta), math.sin(beta)
    return (ddalpha * cb - dalpha * dbeta * sb - ddgamma * ca * sb
            + dgamma * dalpha * sa * sb - dgamma * dbeta * ca * cb,
            ddbeta + ddgamma * sa + dgamma * dalpha * ca,
            ddalpha * sb + dalpha * dbeta * cb + ddgamma * ca * cb
            - dgamma * dalpha * sa * cb - dgamma * dbeta * ca * sb)


def deck_angular_velocity(alpha, beta, gamma,  # noqa: ARG001 (the Euler triple of Eqs. 1-2)
                          dalpha, dbeta, dgamma) -> np.ndarray:
    """Return omega_P of Eq. (10) in deck axes [rad/s], shape (3,).

    It takes the whole Euler triple and its rates, as Eqs. (1)-(2) name them; Eq. (10) does
    not depend on gamma.
    """
    return np.array(_omega(alpha, beta, dalpha, dbeta, dgamma))


def deck_angular_acceleration(alpha, beta, gamma,  # noqa: ARG001 (as deck_angular_velocity)
                              dalpha, dbeta, dgamma, ddalpha, ddbeta, ddgamma) -> np.ndarray:
    """Return the time derivative of Eq. (10) in deck axes [rad/s^2], shape (3,)."""
    return np.array(_omega_dot(alpha, beta, dalpha, dbeta, dgamma, ddalpha, ddbeta, ddgamma))


def deck_velocity(q, qd) -> tuple[np.ndarray, np.ndarray]:
    """Return (velocity of C, angular velocity Eq. 10), both in deck axes [m/s], [rad/s].

    ``q``, ``qd``: generalised coordinates and rates, [theta, X, Y, Z, alpha, beta, gamma, ...]
    (the twist of :func:`deck_pose_twist`).
    """
    q = np.asarray(q, dtype=float)
    out = np.empty(13)
    JIT.deck_pose_twist(np.concatenate([q, np.asarray(qd, dtype=float)]), q.size - PHI, out)
    return out[7:10], out[10:13]


@kernel
def _specific_force(q, qd, qdd, r, gravity):
    """Return point_specific_force and Eq. (10) as float tuples (arrays q, q', q'', r)."""
    a, b, g = q[ALPHA], q[ALPHA + 1], q[ALPHA + 2]
    da, db, dg = qd[ALPHA], qd[ALPHA + 1], qd[ALPHA + 2]
    ddX, ddY, ddZ = qdd[DECK], qdd[DECK + 1], qdd[DECK + 2]
    dda, ddb, ddg = qdd[ALPHA], qdd[ALPHA + 1], qdd[ALPHA + 2]
    t = _t_matrix(a, b, g)
    w = _omega(a, b, da, db, dg)
    wd = _omega_dot(a, b, da, db, dg, dda, ddb, ddg)
    a_c = _mul(t, (ddX, ddY, ddZ))
    e1, e2 = _cross(wd, r), _cross(w, _cross(w, r))
    f0, f1, f2 = a_c[0] + e1[0] + e2[0], a_c[1] + e1[1] + e2[1], a_c[2] + e1[2] + e2[2]
    if gravity:  # -g = +GRAVITY along Z of base: T (0, 0, g) is g times T's last column
        f0, f1, f2 = f0 + t[2] * GRAVITY, f1 + t[5] * GRAVITY, f2 + t[8] * GRAVITY
    return (f0, f1, f2), w


@kernel
def imu_reading(q, qd, qdd, r, gravity, z, k, bias, out):
    """Write one IMU sample into ``out``: specific force [m/s^2], then angular rate [rad/s].

    Deck axes: bias += z[:6] (ka, ka, ka, kg, kg, kg) (random walk), then out = ideal + bias +
    z[6:] (sa, sa, sa, sg, sg, sg) (white noise); ``k`` = (ka, kg, sa, sg), ``bias`` (6,)
    updated in place.
    """
    accel, gyro = _specific_force(q, qd, qdd, r, gravity)
    for i in range(3):
        bias[i] = bias[i] + z[i] * k[0]
        bias[3 + i] = bias[3 + i] + z[3 + i] * k[1]
    for i in range(3):
        out[i] = accel[i] + bias[i] + z[6 + i] * k[2]
        out[3 + i] = gyro[i] + bias[3 + i] + z[9 + i] * k[3]


@kernel
def deck_pose_twist(y, n, out):
    """Write the deck's pose and twist for the state ``y`` of ``n`` balls into ``out`` (13,).

    ``out`` = C in base [m], the quaternion (x, y, z, w) of R (Eqs. 1-2), the velocity of C
    [m/s] and Eq. (10) [rad/s], both in deck axes (deck/pose, deck/twist).
    """
    N = PHI + n
    a, b, g = y[ALPHA], y[ALPHA + 1], y[ALPHA + 2]
    quat = euler_quaternion(a, b, g)
    v = _mul(_t_matrix(a, b, g), (y[N + DECK], y[N + DECK + 1], y[N + DECK + 2]))
    w = _omega(a, b, y[N + ALPHA], y[N + ALPHA + 1], y[N + ALPHA + 2])
    for i in range(3):
        out[i] = y[DECK + i]
        out[7 + i] = v[i]
        out[10 + i] = w[i]
    for i in range(4):
        out[3 + i] = quat[i]


@kernel
def imu_readings(ys, qdds, n, r, gravity, z, k, bias, out):
    """Write the IMU samples at the states ``ys`` (rows) into the rows of ``out``.

    :func:`imu_reading` of each row in turn, with the accelerations ``qdds`` (rows), the
    next 12 of the normals ``z`` and the bias carried on from row to row.
    """
    N = PHI + n
    for j in range(ys.shape[0]):
        imu_reading(ys[j, :N], ys[j, N:], qdds[j], r, gravity, z[12 * j:12 * j + 12], k, bias,
                    out[j])


@kernel
def reading_and_pose(y, n, qdd, r, gravity, z, k, bias, out):
    """Write the state ``y``, the IMU sample and the deck's pose and twist there into ``out``.

    ``out[:2N]``: ``y``; then :func:`imu_reading` (specific force, angular rate) with the
    accelerations ``qdd``, the normals ``z`` (12) and the bias updated in place; then
    :func:`deck_pose_twist` (13). All in one call.
    """
    N = PHI + n
    for i in range(2 * N):
        out[i] = y[i]
    imu_reading(y[:N], y[N:], qdd, r, gravity, z, k, bias, out[2 * N:2 * N + 6])
    deck_pose_twist(y, n, out[2 * N + 6:2 * N + 19])


@kernel
def deck_pose_twists(ys, n, out):
    """Write :func:`deck_pose_twist` of each state ``ys[j]`` into ``out[j]`` (13 columns)."""
    for j in range(ys.shape[0]):
        deck_pose_twist(ys[j], n, out[j])


JIT, PY = kernel.build()
"""The IMU model's kernels compiled (numba) and as Python (see abb_ros.model.jit)."""


def point_specific_force(q, qd, qdd, r, gravity: bool = False) -> np.ndarray:
    """Return the specific force at point r (deck axes, from C) [m/s^2], deck axes, shape (3,).

    a_C + w' x r + w x (w x r) - g, with a_C = R^T (X'', Y'', Z'').
    """
    return np.array(_specific_force(_array(q), _array(qd), _array(qdd), _array(r),
                                    bool(gravity))[0])


def _array(v) -> np.ndarray:
    return np.asarray(v, dtype=float)


@dataclass(frozen=True)
class ImuConfig:
    """IMU mounting and noise, SI. Densities are per sqrt(Hz); ``rate`` the output rate [Hz].

    accel: noise density [m/s^2/sqrt(Hz)], turn-on bias std [m/s^2], bias random walk
    [m/s^3/sqrt(Hz)]; gyro: [rad/s/sqrt(Hz)], [rad/s], [rad/s^2/sqrt(Hz)].
    """

    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rate: float = 1000.0
    gravity: bool = False
    accel_noise_density: float = 0.0
    accel_bias: float = 0.0
    accel_bias_random_walk: float = 0.0
    gyro_noise_density: float = 0.0
    gyro_bias: float = 0.0
    gyro_bias_random_walk: float = 0.0

    @property
    def accel_variance(self) -> float:
        """Variance of one accelerometer sample's white noise, density^2 * rate [(m/s^2)^2]."""
        return self.accel_noise_density ** 2 * self.rate

    @property
    def gyro_variance(self) -> float:
        """Variance of one gyro sample's white noise, density^2 * rate [(rad/s)^2]."""
        return self.gyro_noise_density ** 2 * self.rate


TYPICAL_IMU = ImuConfig(rate=1000.0, accel_noise_density=1.5e-3, accel_bias=0.02,
                        accel_bias_random_walk=3e-3, gyro_noise_density=2.4e-4, gyro_bias=1e-3,
                        gyro_bias_random_walk=2e-5)
"""A MEMS-class IMU at C, 1 kHz: the simulator node's default and ``abb-sim run``'s, so that
live and headless recordings of the same scenario and seed hold the same readings."""


@dataclass(frozen=True)
class ImuReading:
    """One IMU sample, deck axes: specific force [m/s^2] and angular rate [rad/s]."""

    accel: np.ndarray
    gyro: np.ndarray


@dataclass
class ImuModel:
    """IMU readings with seeded noise and bias (see the module docstring)."""

    config: ImuConfig
    seed: int = 0
    rng: np.random.Generator = field(init=False, repr=False)

    def __post_init__(self):
        self.reconfigure(self.config)
        self.reset()

    def reset(self) -> None:
        """Re-seed: the readings repeat from the start."""
        self.rng = np.random.default_rng(self.seed)
        c = self.config
        self.bias = np.concatenate([self.rng.normal(0.0, 1.0, 3) * c.accel_bias,
                                    self.rng.normal(0.0, 1.0, 3) * c.gyro_bias])
        """[accel (m/s^2), gyro (rad/s)] biases, deck axes"""
        self._normals = NormalStream(self.rng)

    def reconfigure(self, config: ImuConfig) -> None:
        """Apply new mounting/noise parameters; the generator and the bias state carry on."""
        self.config = config
        sqrt_dt = math.sqrt(1.0 / config.rate)
        self._k = np.array([config.accel_bias_random_walk * sqrt_dt,
                            config.gyro_bias_random_walk * sqrt_dt,
                            math.sqrt(config.accel_variance), math.sqrt(config.gyro_variance)])
        self._position = np.asarray(config.position, dtype=float)

    def read(self, q, qd, qdd) -> ImuReading:
        """Return the reading at the state (q, q', q''), advancing the noise generator.

        bias += z rw sqrt(dt); reading = ideal + bias + z sqrt(variance), in one compiled
        kernel (:func:`imu_reading`).
        """
        # One draw of 12 normals per sample whatever the settings, so that the sequence of
        # the generator (and so every later reading) does not depend on which terms are on.
        z = self._normals.take(12)
        out = np.empty(6)
        JIT.imu_reading(q, qd, qdd, self._position, self.config.gravity, z, self._k,
                        self.bias, out)
        return ImuReading(out[:3], out[3:])

    def read_with_pose(self, y, n: int, qdd, out) -> None:
        """Write ``y`` (``n`` balls, 2N values), then :meth:`read` there into ``out``.

        ``out[:2N]`` the state, ``out[2N:2N + 6]`` the reading (accel, gyro), ``out[2N + 6:
        2N + 19]`` the deck's pose and twist (:func:`deck_pose_twist`): the same numbers,
        generator and bias as :meth:`read`, in one compiled call.
        """
        JIT.reading_and_pose(y, n, qdd, self._position, self.config.gravity,
                             self._normals.take(12), self._k, self.bias, out)

    def read_many(self, ys, qdds, n: int) -> np.ndarray:
        """Return the readings at the states ``ys`` (rows, ``n`` balls), rows (accel, gyro).

        Shape (len(ys), 6); the readings, generator and bias of :meth:`read` at each state
        (q, q' of the row, q'' the row of ``qdds``) in turn, in one compiled call.
        """
        z = self._normals.take(12 * len(ys))
        out = np.empty((len(ys), 6))
        JIT.imu_readings(ys, qdds, n, self._position, self.config.gravity, z, self._k,
                         self.bias, out)
        return out

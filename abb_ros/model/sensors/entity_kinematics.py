"""Ground-truth kinematics of the drive's bodies in the base frame, and states set from them.

The bodies (the simulator serves them as simulation_interfaces entities): the deck (its centre
C, the point of ``deck/pose``), the rotor (spinning by theta about the deck's z axis through
C) and each ball (a point on the race of radius R at angle psi_i = theta + phi_i from the
deck's x axis, in the deck's xy plane through C: the kernel's convention).

All in the base frame (the inertial XYZ of the paper), SI units. With R the deck-to-base
rotation (Eqs. 1-2), w and w' the deck's angular velocity Eq. (10) and its derivative in deck
axes, e_z the deck's z axis and r_i = R_race (cos psi_i, sin psi_i, 0) (deck axes):

- deck: position C = (X, Y, Z), orientation R, velocity C', angular velocity R w,
  acceleration C'', angular acceleration R w' (d/dt (R w) = R (w' + w x w) = R w');
- rotor: position C, orientation R Rz(theta), angular velocity R (w + theta' e_z), angular
  acceleration R (w' + theta'' e_z + w x theta' e_z);
- ball i: position C + R r_i; velocity C' + R (w x r_i + psi_i' e_z x r_i); acceleration
  C'' + R (w' x r_i + w x (w x r_i) + 2 w x (psi_i' e_z x r_i) + psi_i'' e_z x r_i
  - psi_i'^2 r_i); orientation and angular velocity those of its radial frame R Rz(psi_i)
  (x outward, z along the spin axis): the balls are point masses of the model, their own
  spin is no state.

Setting (:func:`with_ball`, :func:`with_deck`) works the other way round: a ball's position
gives phi_i (it must lie on its race), its velocity phi_i' (it must be along the race); the
deck's pose and twist give (X, Y, Z, alpha, beta, gamma) and their rates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from abb_ros.model.dynamics.integrate import Simulation, StateError
from abb_ros.model.dynamics.kernels.layout import MAX_ANGLE, MAX_BALL_RATE, MAX_TRANSLATION
from abb_ros.model.dynamics.state import StateLayout, wrap_angle
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.sensors.imu import (
    deck_angular_acceleration,
    deck_velocity,
    euler_quaternion,
    euler_rotation,
)

__all__ = ['DECK', 'ROTOR', 'ball_name', 'entity_names', 'Kinematics', 'kinematics',
           'EntityError', 'with_ball', 'with_deck', 'with_entity', 'ON_RACE_TOL', 'UNIT_TOL',
           'MAX_DECK_TWIST']

DECK = 'deck'
ROTOR = 'rotor'
ON_RACE_TOL = 1e-6
"""How far a ball set by position may be off its race [m] (radially and out of plane), and
how fast across it [m/s]: a micrometre, far below the race radius and above float noise."""
UNIT_TOL = 1e-6
"""How far from 1 the norm of a quaternion set may be."""
MAX_DECK_TWIST = 1000.0
"""Largest deck velocity [m/s] and angular velocity [rad/s] component set, as
``disturbance.shock_velocity``'s: the deck leaves its envelope within microseconds beyond."""
MAX_SPEED = 1.0e7
"""Largest component of any velocity set [m/s, rad/s] before the finer checks (no arithmetic on
a value near 1e308 overflows)."""


def ball_name(i: int) -> str:
    """Entity name of ball ``i`` (0-based): ``ball_1`` for i = 0, as in joint_states."""
    return f'ball_{i + 1}'


def entity_names(n: int) -> list[str]:
    """Return the names of the drive's entities: deck, rotor, ball_1..ball_n."""
    return [DECK, ROTOR] + [ball_name(i) for i in range(n)]


class EntityError(ValueError):
    """A state that the named entity cannot take (the reason is the message)."""


@dataclass(frozen=True)
class Kinematics:
    """Pose, twist and acceleration of one body in the base frame (SI)."""

    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]
    """Quaternion (x, y, z, w)."""
    linear_velocity: tuple[float, float, float]
    angular_velocity: tuple[float, float, float]
    linear_acceleration: tuple[float, float, float]
    angular_acceleration: tuple[float, float, float]


def _quaternion(rotation: np.ndarray) -> tuple[float, float, float, float]:
    """Return the unit quaternion (x, y, z, w) of a rotation matrix (w >= 0)."""
    m = rotation
    w = math.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2,
                      m[2, 1] - m[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2,
                      m[0, 2] - m[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2,
                      m[1, 0] - m[0, 1])
    return (x, y, z, w)


def _rz(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _t(v) -> tuple[float, float, float]:
    return tuple(float(x) for x in v)


def _t4(v) -> tuple[float, float, float, float]:
    """Return the quaternion of deck/pose itself (same arithmetic, same bits)."""
    return tuple(float(x) for x in v)


def kinematics(y: np.ndarray, qdd: np.ndarray, params: DriveParams) -> dict[str, Kinematics]:
    """Return every entity's :class:`Kinematics` at state ``y`` with accelerations ``qdd``.

    ``qdd`` is q'' at ``y`` (``Simulation.accelerations()``); keys in :func:`entity_names`
    order.
    """
    s = StateLayout.of(params.n)
    q, qd = y[s.q], y[s.qd]
    X, angles = s.translation(y), s.deck(y)[3:]
    Xd, rates = s.deck_rates(y)[:3], s.deck_rates(y)[3:]
    Xdd, angle_acc = qdd[1:4], qdd[4:7]
    rotation = euler_rotation(*angles)
    _, w_deck = deck_velocity(q, qd)
    wd_deck = deck_angular_acceleration(*angles, *rates, *angle_acc)
    theta, omega, theta_dd = float(q[0]), float(qd[0]), float(qdd[0])
    ez = np.array([0.0, 0.0, 1.0])
    out = {DECK: Kinematics(_t(X), _t4(euler_quaternion(*angles)), _t(Xd), _t(rotation @ w_deck),
                            _t(Xdd), _t(rotation @ wd_deck))}
    w_rotor = w_deck + omega * ez
    out[ROTOR] = Kinematics(
        _t(X), _quaternion(rotation @ _rz(theta)), _t(Xd), _t(rotation @ w_rotor), _t(Xdd),
        _t(rotation @ (wd_deck + theta_dd * ez + np.cross(w_deck, omega * ez))))
    phi, phi_d, phi_dd = s.phi(y), s.phi_rates(y), qdd[7:]
    for i in range(params.n):
        psi = theta + float(phi[i])
        psi_d, psi_dd = omega + float(phi_d[i]), theta_dd + float(phi_dd[i])
        r = np.array([params.R * math.cos(psi), params.R * math.sin(psi), params.z_B])
        r_rel_v = psi_d * np.cross(ez, r)
        v = Xd + rotation @ (np.cross(w_deck, r) + r_rel_v)
        a = Xdd + rotation @ (np.cross(wd_deck, r) + np.cross(w_deck, np.cross(w_deck, r))
                              + 2 * np.cross(w_deck, r_rel_v) + psi_dd * np.cross(ez, r)
                              - psi_d ** 2 * r)
        frame = rotation @ _rz(psi)
        w_ball = w_deck + psi_d * ez
        out[ball_name(i)] = Kinematics(
            _t(X + rotation @ r), _quaternion(frame), _t(v), _t(rotation @ w_ball), _t(a),
            _t(rotation @ (wd_deck + psi_dd * ez + np.cross(w_deck, psi_d * ez))))
    return out


def _within(field: str, values, limit: float, unit: str, why: str) -> None:
    """Refuse any of ``values`` (x, y, z of ``field``) beyond +-``limit``."""
    for axis, value in zip('xyz', values):
        if not abs(value) <= limit:
            raise EntityError(f'state.{field}.{axis} = {value:.6g} {unit}; valid: within '
                              f'+-{limit:g} {unit} ({why})')


def unit_quaternion(orientation) -> np.ndarray:
    """Return ``orientation`` (x, y, z, w) normalised; EntityError unless its norm is ~1."""
    quat = np.asarray(orientation, dtype=float)
    if not np.all(np.isfinite(quat)) or not np.all(np.abs(quat) <= 2.0):
        norm = math.inf
    else:
        norm = float(np.linalg.norm(quat))
    if abs(norm - 1.0) > UNIT_TOL:
        raise EntityError(f'state.pose.orientation: |q| = {norm:.9g}; valid: a unit '
                          f'quaternion (x, y, z, w) with |q| within {UNIT_TOL:g} of 1')
    return quat / norm


def with_ball(y: np.ndarray, params: DriveParams, i: int, position, velocity,
              orientation=(0.0, 0.0, 0.0, 1.0)) -> np.ndarray:
    """Return ``y`` with ball ``i`` at base-frame ``position`` moving at ``velocity``.

    The point must be on the ball's race (within :data:`ON_RACE_TOL`) and the velocity along
    it relative to the deck, with a ball rate phi_i' within the model's envelope
    (``MAX_BALL_RATE``); ``orientation`` must be a unit quaternion (the ball's own is its
    radial frame: the value is checked, not used). Otherwise :class:`EntityError` names the
    field and what is valid.
    """
    unit_quaternion(orientation)
    reach = MAX_TRANSLATION + params.R + abs(params.z_B) + ON_RACE_TOL
    _within('pose.position', position, reach, 'm', 'the deck envelope plus the race radius')
    _within('twist.linear', velocity, MAX_SPEED, 'm/s', 'far beyond any ball speed')
    s = StateLayout.of(params.n)
    q, qd = y[s.q], y[s.qd]
    rotation = euler_rotation(*s.deck(y)[3:])
    r = rotation.T @ (np.asarray(position, dtype=float) - s.translation(y))
    radius = math.hypot(r[0], r[1])
    if abs(radius - params.R) > ON_RACE_TOL or abs(r[2] - params.z_B) > ON_RACE_TOL:
        raise EntityError(
            f'{ball_name(i)} must lie on its race: {radius:.9g} m from the spin axis '
            f'(R = {params.R:.9g} m) and {r[2] - params.z_B:.3g} m off the race plane at '
            f'z_B = {params.z_B:g} m (tolerance {ON_RACE_TOL:g} m)')
    psi = math.atan2(r[1], r[0])
    _, w_deck = deck_velocity(q, qd)
    v_rel = (rotation.T @ (np.asarray(velocity, dtype=float) - s.deck_rates(y)[:3])
             - np.cross(w_deck, r))
    tangent = np.array([-math.sin(psi), math.cos(psi), 0.0])
    across = v_rel - float(tangent @ v_rel) * tangent
    if float(np.linalg.norm(across)) > ON_RACE_TOL:
        raise EntityError(f'{ball_name(i)} can only move along its race: the velocity has '
                          f'{float(np.linalg.norm(across)):.3g} m/s across it')
    out = y.copy()
    theta, omega = float(q[0]), float(qd[0])
    rate = float(tangent @ v_rel) / params.R - omega
    if abs(rate) > MAX_BALL_RATE:
        raise EntityError(
            f'state.twist.linear: {ball_name(i)} would turn at phi\' = {rate:.6g} rad/s in the '
            f'rotor; valid: |phi\'| <= {MAX_BALL_RATE:g} rad/s (the model\'s envelope), a speed '
            f'along the race within {MAX_BALL_RATE * params.R:.6g} m/s of the rotor\'s')
    old = float(s.phi(out)[i])   # the nearest angle to the old one: no turns added
    s.phi(out)[i] = old + float(wrap_angle(psi - theta - old))
    s.phi_rates(out)[i] = rate
    return out


def with_deck(y: np.ndarray, params: DriveParams, position, orientation, velocity,
              angular_velocity) -> np.ndarray:
    """Return ``y`` with the deck at a new pose and twist (base frame).

    The deck's centre C at ``position`` in ``orientation`` (x, y, z, w), moving at
    ``velocity`` and turning at ``angular_velocity``.

    The angles (alpha, beta, gamma) of R = Rz(gamma) Rx(alpha) Ry(beta) and their rates
    follow from the quaternion and Eq. (10). Refused with :class:`EntityError` naming the
    field and what is valid: a quaternion far from unit length, a position or angles outside
    the model's envelope (``MAX_TRANSLATION``, ``MAX_ANGLE``: the next step would stop), a
    twist component beyond :data:`MAX_DECK_TWIST`.
    """
    x, yq, z, w = unit_quaternion(orientation)
    _within('pose.position', position, MAX_TRANSLATION, 'm', "the model's envelope")
    _within('twist.linear', velocity, MAX_DECK_TWIST, 'm/s', 'as disturbance.shock_velocity')
    _within('twist.angular', angular_velocity, MAX_DECK_TWIST, 'rad/s',
            'as disturbance.shock_velocity')
    m = np.array([[1 - 2 * (yq * yq + z * z), 2 * (x * yq - z * w), 2 * (x * z + yq * w)],
                  [2 * (x * yq + z * w), 1 - 2 * (x * x + z * z), 2 * (yq * z - x * w)],
                  [2 * (x * z - yq * w), 2 * (yq * z + x * w), 1 - 2 * (x * x + yq * yq)]])
    # R = Rz(g) Rx(a) Ry(b): R[2,1] = sin a, R[2,0] = -cos a sin b, R[2,2] = cos a cos b,
    # R[0,1] = -cos a sin g, R[1,1] = cos a cos g.
    alpha = math.asin(max(-1.0, min(1.0, m[2, 1])))
    if math.cos(alpha) < 1e-6:
        raise EntityError('deck orientation at alpha = +-90 deg, where the angles of Eqs. '
                          '(1)-(2) are undefined')
    beta = math.atan2(-m[2, 0], m[2, 2])
    gamma = math.atan2(-m[0, 1], m[1, 1])
    for angle, value in (('alpha', alpha), ('beta', beta), ('gamma', gamma)):
        if abs(value) > MAX_ANGLE:
            raise EntityError(
                f'state.pose.orientation: {angle} = {value:.6g} rad (R = Rz(gamma) Rx(alpha) '
                f"Ry(beta)); valid: alpha, beta, gamma within +-{MAX_ANGLE:g} rad (the model's "
                'envelope)')
    w_deck = m.T @ np.asarray(angular_velocity, dtype=float)
    # Eq. (10) inverted: w = (a' cb - g' ca sb, b' + g' sa, a' sb + g' ca cb).
    ca, sa, cb, sb = math.cos(alpha), math.sin(alpha), math.cos(beta), math.sin(beta)
    dalpha = w_deck[0] * cb + w_deck[2] * sb
    dgamma = (w_deck[2] * cb - w_deck[0] * sb) / ca
    dbeta = w_deck[1] - dgamma * sa
    s = StateLayout.of(params.n)
    out = y.copy()
    s.deck(out)[:] = [*np.asarray(position, dtype=float), alpha, beta, gamma]
    s.deck_rates(out)[:] = [*np.asarray(velocity, dtype=float), dalpha, dbeta, dgamma]
    return out


def with_entity(sim: Simulation, name: str, position, orientation, velocity, angular_velocity,
                trial_steps: int) -> np.ndarray:
    """Return ``sim.y`` with the deck or ball ``name`` set (:func:`with_deck`, :func:`with_ball`).

    Computed with numpy's floating-point errors raised (no RuntimeWarning), then tried on a
    copy of ``sim`` for ``trial_steps`` steps: a state from which they would stop the plant
    (non-finite, out of the envelope) is refused too. :class:`EntityError` says why.
    """
    with np.errstate(all='raise'):
        try:
            if name == DECK:
                y = with_deck(sim.y, sim.params, position, orientation, velocity,
                              angular_velocity)
            else:
                i = entity_names(sim.params.n).index(name) - 2
                y = with_ball(sim.y, sim.params, i, position, velocity, orientation)
        except FloatingPointError as err:
            raise EntityError(f'{name}: the state overflows ({err}); valid: finite values of '
                              "the model's scale") from None
    twin = Simulation(sim.params, sim.omega, sim.dt, spindle=sim.spindle, y0=y, t0=sim.t0,
                      integrator=sim.integrator)
    twin.steps = sim.steps
    twin.set_command(sim.omega_cmd)
    try:
        twin.advance(trial_steps)
        why = '' if np.all(np.isfinite(twin.y)) else 'the state became non-finite'
    except StateError as err:
        why = str(err).split('; ')[0]
    if why:
        raise EntityError(f'{name}: the next step from this state would stop the plant ({why}); '
                          "valid: a state the model's envelope holds for the next publish period")
    return y

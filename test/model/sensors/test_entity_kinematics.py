"""The entities' ground-truth kinematics are the time derivatives of one another, and setting a
state from them gives back the model's coordinates.

Derivatives are checked against five-point central differences along the integrated trajectory
of the Table 1 drive (h = 1e-5 s, the integration step): the stencil's error is h^4/30 times
the fifth derivative, for the fastest motions here (the deck's modes near 1 kHz, the balls at
omega = 600 rad/s) below 1e-8 of each quantity's scale, so a relative tolerance of 1e-6 is far
above the truncation and far below any wrong term (a missing Coriolis term is ~1e-2 of the
scale).
"""

import math

import numpy as np
import pytest

from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.sensors import entity_kinematics as ek
from abb_ros.model.sensors.imu import JIT as SENSORS

TABLE1 = DriveParams()
H = 1e-5
OMEGA = 600.0


def _trajectory(params=TABLE1):
    """Kinematics at five consecutive steps h apart, after some settling."""
    sim = Simulation(params, OMEGA, H)
    sim.advance(2000)
    out = []
    for _ in range(5):
        out.append(ek.kinematics(sim.y.copy(), sim.accelerations(), sim.params))
        sim.advance(1)
    return out


def _d(values):
    """Five-point central difference at the middle of five values h apart."""
    a, b, _, d, e = (np.array(v, dtype=float) for v in values)
    return (a - 8 * b + 8 * d - e) / (12 * H)


def _rate(quats):
    """World angular velocity from five quaternions (x, y, z, w): q' = 1/2 (w, 0) x q."""
    qd = _d(quats)
    x, y, z, w = quats[2]
    # (w_vec, 0) (x) q: vector part = w_q w_vec + w_vec x q_vec; then w_vec = 2 qd q^-1.
    conj = np.array([-x, -y, -z, w])
    a, b = np.array([*qd[:3], qd[3]]), conj
    vec = a[3] * b[:3] + b[3] * a[:3] + np.cross(a[:3], b[:3])
    return 2 * vec


@pytest.fixture(scope='module')
def five_steps():
    return _trajectory()


@pytest.mark.parametrize('name', ek.entity_names(TABLE1.n))
def test_velocity_and_acceleration_are_the_derivatives_of_pose_and_velocity(five_steps, name):
    ks = [k[name] for k in five_steps]
    now = ks[2]

    def close(derivative, field):
        value = np.array(getattr(now, field))
        scale = max(1e-3, np.abs(value).max())
        assert np.allclose(derivative, value, rtol=0, atol=1e-6 * scale), (name, field)

    close(_d([k.position for k in ks]), 'linear_velocity')
    close(_d([k.linear_velocity for k in ks]), 'linear_acceleration')
    close(_rate([k.orientation for k in ks]), 'angular_velocity')
    close(_d([k.angular_velocity for k in ks]), 'angular_acceleration')


def test_the_deck_entity_is_the_deck_pose_topic():
    sim = Simulation(TABLE1, OMEGA, H)
    sim.advance(500)
    deck = ek.kinematics(sim.y, sim.accelerations(), sim.params)[ek.DECK]
    out = np.empty(13)
    SENSORS.deck_pose_twist(sim.y, TABLE1.n, out)
    assert deck.position == tuple(out[:3])
    q = np.array(deck.orientation)
    assert np.allclose(q * np.sign(q[3]), out[3:7] * np.sign(out[6]), rtol=0, atol=1e-12)


def test_balls_sit_on_their_race_at_theta_plus_phi():
    sim = Simulation(TABLE1, OMEGA, H)
    k = ek.kinematics(sim.y, sim.accelerations(), sim.params)
    for i in range(TABLE1.n):
        offset = np.array(k[ek.ball_name(i)].position) - k[ek.DECK].position
        assert math.isclose(np.linalg.norm(offset), TABLE1.R, rel_tol=1e-12)


RACE_ABOVE = DriveParams(z_B=0.005)


@pytest.mark.parametrize('params', [TABLE1, RACE_ABOVE], ids=['z_B=0', 'z_B=5mm'])
def test_setting_a_ball_from_its_own_state_restores_its_angle_and_rate(params):
    sim = Simulation(params, OMEGA, H)
    sim.advance(300)
    y = sim.y.copy()
    k = ek.kinematics(y, sim.accelerations(), sim.params)[ek.ball_name(1)]
    moved = y.copy()
    layout = sim.layout
    layout.phi(moved)[1] += 0.7
    layout.phi_rates(moved)[1] -= 3.0
    back = ek.with_ball(moved, params, 1, k.position, k.linear_velocity)
    assert np.allclose(back, y, rtol=0, atol=1e-9)


def test_setting_the_deck_from_its_own_state_restores_its_coordinates_and_rates():
    sim = Simulation(TABLE1, OMEGA, H)
    sim.advance(300)
    y = sim.y.copy()
    layout = sim.layout
    layout.deck(y)[3:] = (0.01, -0.02, 0.03)   # angles well away from zero
    layout.deck_rates(y)[3:] = (0.5, -0.4, 0.3)
    k = ek.kinematics(y, sim.accelerations(), sim.params)[ek.DECK]
    moved = y.copy()
    layout.deck(moved)[:] = 0.0
    layout.deck_rates(moved)[:] = 0.0
    back = ek.with_deck(moved, TABLE1, k.position, k.orientation, k.linear_velocity,
                        k.angular_velocity)
    assert np.allclose(back, y, rtol=0, atol=1e-12)


def test_a_ball_off_its_race_or_moving_across_it_is_refused_with_the_reason():
    sim = Simulation(TABLE1, OMEGA, H)
    k = ek.kinematics(sim.y, sim.accelerations(), sim.params)[ek.ball_name(0)]
    p = np.array(k.position)
    with pytest.raises(ek.EntityError, match='ball_1 must lie on its race'):
        ek.with_ball(sim.y, TABLE1, 0, p * 1.01, k.linear_velocity)
    with pytest.raises(ek.EntityError, match='along its race'):
        ek.with_ball(sim.y, TABLE1, 0, p, np.array(k.linear_velocity) + (0, 0, 0.1))
    with pytest.raises(ek.EntityError, match='unit quaternion'):
        ek.with_deck(sim.y, TABLE1, (0, 0, 0), (0, 0, 0, 2.0), (0, 0, 0), (0, 0, 0))


def test_balls_of_a_race_above_the_washers_plane_sit_at_z_b_in_the_deck_frame():
    sim = Simulation(RACE_ABOVE, OMEGA, H)
    sim.advance(300)
    y = sim.y.copy()
    k = ek.kinematics(y, sim.accelerations(), sim.params)
    rotation = ek.euler_rotation(*sim.layout.deck(y)[3:])
    for i in range(RACE_ABOVE.n):
        r = rotation.T @ (np.array(k[ek.ball_name(i)].position) - k[ek.DECK].position)
        assert math.isclose(r[2], RACE_ABOVE.z_B, rel_tol=1e-12)
        assert math.isclose(math.hypot(r[0], r[1]), RACE_ABOVE.R, rel_tol=1e-12)


def test_a_ball_velocity_off_the_washers_plane_is_the_derivative_of_its_position():
    steps = _trajectory(RACE_ABOVE)
    name = ek.ball_name(0)
    velocity = np.array(steps[2][name].linear_velocity)
    derivative = _d([s[name].position for s in steps])
    assert np.allclose(derivative, velocity, rtol=0, atol=1e-6 * np.linalg.norm(velocity))


def test_a_ball_of_a_race_above_the_plane_is_refused_in_the_washers_plane():
    sim = Simulation(RACE_ABOVE, OMEGA, H)
    sim.advance(300)
    y = sim.y.copy()
    k = ek.kinematics(y, sim.accelerations(), sim.params)[ek.ball_name(1)]
    rotation = ek.euler_rotation(*sim.layout.deck(y)[3:])
    in_washers_plane = np.array(k.position) - rotation @ (0.0, 0.0, RACE_ABOVE.z_B)
    with pytest.raises(ek.EntityError, match='off the race plane at z_B = 0.005 m'):
        ek.with_ball(y, RACE_ABOVE, 1, in_washers_plane, k.linear_velocity)

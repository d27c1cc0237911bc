"""Deck kinematics (Eqs. 1, 2, 10) and the IMU model of abb_ros.model.sensors.imu.

Every kinematic identity is checked against an independent construction: the matrices of
Eq. (2) multiplied out numerically, finite differences of positions along an analytic
trajectory, the quaternion turned back into a matrix.
"""

import math

import numpy as np
import pytest

from abb_ros.model.sensors.imu import (
    GRAVITY,
    ImuConfig,
    ImuModel,
    deck_angular_acceleration,
    deck_angular_velocity,
    deck_velocity,
    euler_quaternion,
    euler_rotation,
    point_specific_force,
)


def t_matrices(alpha, beta, gamma):
    """T_gamma, T_alpha, T_beta exactly as printed in Eq. (2)."""
    cg, sg = math.cos(gamma), math.sin(gamma)
    ca, sa = math.cos(alpha), math.sin(alpha)
    cb, sb = math.cos(beta), math.sin(beta)
    tg = np.array([[cg, sg, 0], [-sg, cg, 0], [0, 0, 1]])
    ta = np.array([[1, 0, 0], [0, ca, sa], [0, -sa, ca]])
    tb = np.array([[cb, 0, -sb], [0, 1, 0], [sb, 0, cb]])
    return tg, ta, tb


def quat_to_matrix(x, y, z, w):
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


ANGLES = [(0.0, 0.0, 0.0), (0.1, -0.2, 0.3), (-0.25, 0.15, -1.2), (0.3, 0.3, 2.9)]


def trajectory(t):
    """An analytic motion q(t) = [theta, X, Y, Z, alpha, beta, gamma] with its derivatives,
    at the deck's scale (0.1-1 mm, 10-100 mrad, 20-130 Hz)."""
    amp = np.array([0.0, 3e-4, -2e-4, 1e-4, 0.05, -0.08, 0.1])
    w = np.array([0.0, 800.0, 650.0, 300.0, 500.0, 720.0, 130.0])
    ph = np.array([0.0, 0.1, 0.7, -0.3, 1.1, 0.4, -0.9])
    q = amp * np.sin(w * t + ph)
    qd = amp * w * np.cos(w * t + ph)
    qdd = -amp * w ** 2 * np.sin(w * t + ph)
    return q, qd, qdd


@pytest.mark.parametrize('angles', ANGLES)
def test_deck_rotation_is_the_transpose_of_the_euler_product_of_eqs_1_2(angles):
    alpha, beta, gamma = angles
    tg, ta, tb = t_matrices(alpha, beta, gamma)
    rot = euler_rotation(alpha, beta, gamma)
    # Exact algebra, so round-off only.
    np.testing.assert_allclose(rot, (tb @ ta @ tg).T, atol=1e-15)
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-15)


@pytest.mark.parametrize('angles', ANGLES)
def test_quaternion_is_the_same_rotation(angles):
    x, y, z, w = euler_quaternion(*angles)
    assert math.isclose(x * x + y * y + z * z + w * w, 1.0, rel_tol=1e-15)
    np.testing.assert_allclose(quat_to_matrix(x, y, z, w), euler_rotation(*angles), atol=1e-15)


@pytest.mark.parametrize('t', [0.0, 1.3e-3, 7.7e-3])
def test_eq10_angular_velocity_is_the_skew_part_of_rt_rdot(t):
    h = 1e-7
    q, qd, _ = trajectory(t)
    r_minus = euler_rotation(*trajectory(t - h)[0][4:7])
    r_plus = euler_rotation(*trajectory(t + h)[0][4:7])
    rot = euler_rotation(*q[4:7])
    skew = rot.T @ (r_plus - r_minus) / (2 * h)
    w_fd = np.array([skew[2, 1], skew[0, 2], skew[1, 0]])
    # Central difference error ~ (w h)^2 / 6 relative, w <= 800 rad/s, h = 1e-7: ~1e-9.
    np.testing.assert_allclose(deck_angular_velocity(*q[4:7], *qd[4:7]), w_fd,
                               rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize('t', [0.0, 2.1e-3, 5.3e-3])
def test_angular_acceleration_is_the_derivative_of_eq10(t):
    h = 1e-7
    q, qd, qdd = trajectory(t)

    def w_at(s):
        qs, qds, _ = trajectory(s)
        return deck_angular_velocity(*qs[4:7], *qds[4:7])

    wd_fd = (w_at(t + h) - w_at(t - h)) / (2 * h)
    wd = deck_angular_acceleration(*q[4:7], *qd[4:7], *qdd[4:7])
    # Values ~ 1e4 rad/s^2; the difference quotient is good to ~1e-3 absolute.
    np.testing.assert_allclose(wd, wd_fd, rtol=1e-6, atol=1e-2)


@pytest.mark.parametrize('r', [(0.0, 0.0, 0.0), (0.02, -0.01, 0.005)])
@pytest.mark.parametrize('t', [0.0, 3.3e-3])
def test_imu_specific_force_is_the_second_derivative_of_the_mount_point(r, t):
    h = 1e-5

    def p_base(s):
        qs = trajectory(s)[0]
        return qs[1:4] + euler_rotation(*qs[4:7]) @ np.asarray(r)

    a_base = (p_base(t + h) - 2 * p_base(t) + p_base(t - h)) / h ** 2
    q, qd, qdd = trajectory(t)
    a_deck = euler_rotation(*q[4:7]).T @ a_base
    # Accelerations ~ 100 m/s^2; truncation (w h)^2 / 12 ~ 6e-6 relative, round-off
    # 1e-16 * 1e-3 m / h^2 ~ 1e-9 m/s^2.
    np.testing.assert_allclose(point_specific_force(q, qd, qdd, r), a_deck,
                               rtol=1e-4, atol=1e-3)


def test_velocity_of_c_in_deck_axes_is_rt_times_the_base_velocity():
    q, qd, _ = trajectory(2e-3)
    v, w = deck_velocity(q, qd)
    np.testing.assert_allclose(euler_rotation(*q[4:7]) @ v, qd[1:4], atol=1e-18)
    np.testing.assert_allclose(w, deck_angular_velocity(*q[4:7], *qd[4:7]))


def test_gravity_adds_plus_g_along_z_on_a_level_deck_at_rest_and_is_off_by_default():
    q = qd = qdd = np.zeros(7)
    np.testing.assert_allclose(point_specific_force(q, qd, qdd, (0.01, 0, 0), gravity=True),
                               [0, 0, GRAVITY])
    np.testing.assert_array_equal(point_specific_force(q, qd, qdd, (0.01, 0, 0)), 0.0)
    np.testing.assert_array_equal(ImuModel(ImuConfig()).read(q, qd, qdd).accel, 0.0)


NOISY = ImuConfig(rate=1000.0, accel_noise_density=2e-3, accel_bias=0.05,
                  accel_bias_random_walk=1e-3, gyro_noise_density=3e-4, gyro_bias=2e-3,
                  gyro_bias_random_walk=1e-5)


def readings(model, count):
    q = qd = qdd = np.zeros(7)
    out = [model.read(q, qd, qdd) for _ in range(count)]
    return np.array([r.accel for r in out]), np.array([r.gyro for r in out])


def test_same_seed_gives_identical_readings_and_reset_repeats_them():
    a1, g1 = readings(ImuModel(NOISY, seed=7), 50)
    model = ImuModel(NOISY, seed=7)
    a2, g2 = readings(model, 50)
    np.testing.assert_array_equal(a1, a2)
    np.testing.assert_array_equal(g1, g2)
    model.reset()
    np.testing.assert_array_equal(readings(model, 50)[0], a1)
    assert not np.array_equal(readings(ImuModel(NOISY, seed=8), 50)[0], a1)


def test_white_noise_std_is_density_times_sqrt_rate():
    config = ImuConfig(rate=1000.0, accel_noise_density=2e-3, gyro_noise_density=3e-4)
    count = 20000
    a, g = readings(ImuModel(config, seed=1), count)
    # The sample std of 3 x 20000 normals is within ~0.3 % (1/sqrt(2 * 60000)) of the
    # true one; 2 % is > 6 sigma.
    assert np.std(a) == pytest.approx(2e-3 * math.sqrt(1000.0), rel=0.02)
    assert np.std(g) == pytest.approx(3e-4 * math.sqrt(1000.0), rel=0.02)
    assert config.accel_variance == pytest.approx((2e-3) ** 2 * 1000.0)


def test_bias_random_walk_increments_have_std_rw_over_sqrt_rate():
    config = ImuConfig(rate=500.0, accel_bias_random_walk=1e-3, gyro_bias_random_walk=1e-5)
    a, g = readings(ImuModel(config, seed=3), 10001)
    # No white noise, no turn-on bias: the reading is the bias; its steps are the walk.
    assert np.std(np.diff(a, axis=0)) == pytest.approx(1e-3 / math.sqrt(500.0), rel=0.03)
    assert np.std(np.diff(g, axis=0)) == pytest.approx(1e-5 / math.sqrt(500.0), rel=0.03)


def test_turn_on_bias_is_constant_without_walk_and_scaled_by_its_std():
    config = ImuConfig(accel_bias=0.05, gyro_bias=2e-3)
    a, g = readings(ImuModel(config, seed=11), 20)
    np.testing.assert_array_equal(a, np.broadcast_to(a[0], a.shape))
    assert 0 < np.max(np.abs(a[0])) < 5 * 0.05  # a draw of N(0, 0.05^2), within 5 sigma
    assert 0 < np.max(np.abs(g[0])) < 5 * 2e-3


def test_the_compiled_imu_and_deck_kernels_equal_their_python_twins_bit_for_bit():
    """What ABB_ROS_NO_JIT runs (the kernels' Python source) is what the node runs."""
    from abb_ros.model.sensors import imu
    rng = np.random.default_rng(4)
    q, qd, qdd = rng.normal(0, 1e-2, 9), rng.normal(0, 1.0, 9), rng.normal(0, 10.0, 9)
    y = np.concatenate([q, qd])   # n = 2
    r, z, k = np.array([0.01, -0.02, 0.003]), rng.standard_normal(12), rng.random(4)
    outs = []
    for kern in (imu.JIT, imu.PY):
        bias, out, pose = np.full(6, 0.1), np.empty(6), np.empty(13)
        kern.imu_reading(q, qd, qdd, r, True, z, k, bias, out)
        kern.deck_pose_twist(y, 2, pose)
        outs.append(np.concatenate([bias, out, pose]))
    assert outs[0].tobytes() == outs[1].tobytes()


def test_normals_taken_from_blocks_are_the_generators_own_draws_in_order():
    """NormalStream (IMU noise, FG jitter, speed noise): handing out a block k at a time, across
    block boundaries and for takes larger than a block, gives what drawing k at a time gives."""
    from abb_ros.model.sensors.normals import NormalStream
    sizes = [12, 1, 0, 7, 30, 12, 5, 50, 3] * 10
    stream = NormalStream(np.random.default_rng(9), block=40)
    direct = np.random.default_rng(9)
    for k in sizes:
        assert stream.take(k).tolist() == direct.standard_normal(k).tolist()

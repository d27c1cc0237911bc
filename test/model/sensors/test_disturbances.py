"""Disturbances (shock, disc swap) and sensor faults, in the model layer (no ROS)."""

import math

import numpy as np
import pytest

from abb_ros.io.files.scenario import load_scenario
from abb_ros.io.wire import ros_messages
from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.equations import n_coords
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.sensors.disturbances import apply_shock, deck_twist_matrix, swap_disc
from abb_ros.model.sensors.faults import ImuFaults, SpeedFaults
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuModel
from abb_ros.model.sensors.sampling import PlantSampler
from abb_ros.model.sensors.speed_sensor import SpeedSensor
from abb_ros.model.stability.equilibrium import balanced_equilibrium

STEP = [1e-3, -2e-3, 5e-4, 0.02, -0.01, 0.03]   # m/s, rad/s


def _tilted_state(n=2):
    y = initial_state(load_scenario('p3').params.replace(n=n), 300.0)
    N = n_coords(n)
    y[4:7] = [0.05, -0.08, 0.3]                     # alpha, beta, gamma [rad]
    y[N + 1:N + 7] = [1e-3, 2e-3, -1e-3, 0.4, -0.2, 0.1]
    return y


def test_a_shock_steps_the_deck_twist_by_exactly_the_step_and_leaves_positions():
    y = _tilted_state()
    after = apply_shock(y, 2, STEP)
    twist = np.array(ros_messages.deck_pose_twist_content(y, 2)[1])
    twist_after = np.array(ros_messages.deck_pose_twist_content(after, 2)[1])
    np.testing.assert_allclose(twist_after - twist, STEP, rtol=0, atol=1e-15)
    N = n_coords(2)
    assert np.array_equal(after[:N], y[:N])
    assert np.array_equal(after[N + 7:], y[N + 7:]) and after[N] == y[N]


def test_the_twist_matrix_is_the_rotation_and_eq10_at_zero_angles():
    y = initial_state(load_scenario('p3').params, 300.0)
    y[4:7] = 0.0
    np.testing.assert_array_equal(deck_twist_matrix(y, 2), np.eye(6))


def test_a_disc_swap_keeps_every_mass_where_it_is():
    """Kernel convention (kernels.eom.assemble): G at theta, ball i at theta + phi_i. After the
    swap by delta, G is at the old theta + delta and each ball where it was."""
    y = _tilted_state(n=3)
    delta = math.radians(40.0)
    after = swap_disc(y, 3, delta)
    assert after[0] == pytest.approx(y[0] + delta)
    np.testing.assert_allclose(after[0] + after[7:10], y[0] + y[7:10], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(after[1:7], y[1:7])
    np.testing.assert_array_equal(after[10:], y[10:])


def test_a_disc_swap_moves_the_kernel_s_imbalance_force_by_delta():
    """With the balls removed (n = 0) the in-plane inertial load of G is M eps omega^2 along
    the angle theta: after a swap by delta the load's direction turns by delta."""
    p = load_scenario('p3').params.replace(n=0)
    y = initial_state(p, 300.0, deck0=np.zeros(6))
    delta = math.radians(75.0)

    def force_angle(state):
        solver = kernels.solver_scratch(0)
        kernels.PY.assemble(state, 0, kernels.pack_params(p), 0.0, solver.A, solver.W, solver.f,
                            solver.B, solver.fb)
        return math.atan2(solver.f[1], solver.f[0])

    turned = force_angle(swap_disc(y, 0, delta)) - force_angle(y)
    assert math.remainder(turned - delta, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.slow
def test_after_a_disc_swap_the_balls_settle_at_the_new_phi_star():
    """P3 (metal washers), settled at phi* of eps = 0.25 mm; a disc of eps = 0.15 mm with its
    imbalance 30 deg further: the balls re-settle at the new phi* (from the new G)."""
    p = load_scenario('p3').params
    omega = 2.7 * p.omega0
    old = balanced_equilibrium(p).phi_star
    y = initial_state(p, omega, phi0=old, deck0=np.zeros(6))
    new_p = p.replace(eps=0.15e-3)
    new = balanced_equilibrium(new_p).phi_star
    sim = Simulation(new_p, omega, y0=swap_disc(y, 2, math.radians(30.0)))
    just_after = np.degrees(sim.phi)
    sim.advance(40000)                                     # 4 s
    settled = np.degrees(sim.phi)
    assert np.abs(np.sort(just_after) - np.sort(np.degrees(new))).max() > 10
    np.testing.assert_allclose(np.sort(settled), np.sort(np.degrees(new)), atol=0.5)
    assert sim.rbar < 1e-4


def _sampler(imu_faults=None, speed_faults=None, seed=4):
    p = load_scenario('p3').params
    sim = Simulation(p, 2.7 * p.omega0)
    return PlantSampler(sim, ImuModel(TYPICAL_IMU, seed), 10, 10, speed=SpeedSensor(seed=seed),
                        imu_faults=imu_faults, speed_faults=speed_faults)


def _periods(sampler, count):
    return [s for _ in range(count) for s in sampler.next_period()]


def test_imu_dropout_gives_no_reading_and_clearing_it_gives_back_the_fault_free_ones():
    clean = _periods(_sampler(), 60)
    faults = ImuFaults()
    sampler = _sampler(imu_faults=faults)
    first = _periods(sampler, 20)
    faults.dropout = True
    dropped = _periods(sampler, 20)
    faults.dropout = False
    last = _periods(sampler, 20)
    assert all(s.imu is None for s in dropped) and all(s.y is not None for s in dropped)
    for s, ref in zip(first + last, clean[:20] + clean[40:]):
        np.testing.assert_array_equal(s.imu.accel, ref.imu.accel)


def test_a_stuck_imu_repeats_its_last_reading():
    faults = ImuFaults()
    sampler = _sampler(imu_faults=faults)
    before = _periods(sampler, 10)[-1].imu
    faults.stuck = True
    stuck = _periods(sampler, 10)
    assert all(np.array_equal(s.imu.accel, before.accel)
               and np.array_equal(s.imu.gyro, before.gyro) for s in stuck)
    faults.stuck = False
    assert not np.array_equal(_periods(sampler, 1)[0].imu.accel, before.accel)


def test_a_bias_step_shifts_the_imu_readings_by_the_step():
    clean = _periods(_sampler(), 30)
    step_a, step_g = (0.5, -0.2, 1.0), (0.01, 0.0, -0.03)
    faulty = _periods(_sampler(imu_faults=ImuFaults(accel_bias_step=step_a,
                                                    gyro_bias_step=step_g)), 30)
    accel = np.array([s.imu.accel - r.imu.accel for s, r in zip(faulty, clean)])
    gyro = np.array([s.imu.gyro - r.imu.gyro for s, r in zip(faulty, clean)])
    np.testing.assert_allclose(accel, np.tile(step_a, (30, 1)), atol=1e-12)
    np.testing.assert_allclose(gyro, np.tile(step_g, (30, 1)), atol=1e-12)


def test_speed_dropout_and_noise_act_on_the_speed_reading_only():
    clean = _periods(_sampler(), 2100)
    faults = SpeedFaults(seed=4)
    sampler = _sampler(speed_faults=faults)
    faults.dropout = True
    dropped = _periods(sampler, 100)
    faults.dropout, faults.noise = False, 5.0
    noisy = _periods(sampler, 2000)
    assert all(s.speed is None and s.y is not None for s in dropped)
    err = np.array([s.speed - r.speed for s, r in zip(noisy, clean[100:])])
    # the std of n Gaussian draws scatters by 1/sqrt(2 (n - 1)) of the true one: four of those
    assert np.std(err) == pytest.approx(5.0, rel=4 / np.sqrt(2 * (len(err) - 1)))
    assert all(np.array_equal(s.y, r.y) for s, r in zip(noisy, clean[100:]))

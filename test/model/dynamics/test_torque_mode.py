"""Torque mode: the spindle as a degree of freedom driven by a DC/BLDC motor.

Torque mode: the spindle as a degree of freedom driven by a DC/BLDC motor (docs/torque_mode.md):
the drive model, an ideal drive reproducing speed mode, the Sommerfeld stall at the deck resonance,
and the scenario schema.
"""

import math
import re

import numpy as np
import pytest

from abb_ros.io.files.scenario import CurrentCommand, load_scenario
from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.dynamics.spindle import ConstantSpeed, TorqueMotor
from abb_ros.model.parameters.params import DriveParams, ParamError
from abb_ros.model.stability.linear import natural_frequencies

DT = 1e-4


# ---- the motor model ------------------------------------------------------------------------

def test_current_saturates_at_the_limit_and_at_the_supply_voltage():
    """The winding current follows the command up to I_max, and near the back-EMF the supply
    voltage limits it to (V_s - K_t omega) / R_w, braking beyond."""
    motor = TorqueMotor(K_t=0.01, R_w=2.0, I_max=1.0, V_s=12.0)
    assert motor.current(0.0, 0.3) == 0.3
    assert motor.current(0.0, 5.0) == 1.0 and motor.current(0.0, -5.0) == -1.0
    # at 1000 rad/s the back-EMF is 10 V: at most (12 - 10) / 2 = 1 A up, (-12 - 10) / 2 down
    assert motor.current(1000.0, 0.9) == pytest.approx(0.9)
    assert motor.current(1100.0, 0.9) == pytest.approx((12.0 - 11.0) / 2.0)
    assert motor.current(1300.0, 0.0) == pytest.approx((12.0 - 13.0) / 2.0)   # braking


def test_bad_motor_parameters_are_refused_by_their_parameter_name():
    """A zero, negative or NaN motor parameter is a ParamError naming motor.<name>."""
    with pytest.raises(ParamError, match="'motor.torque_constant'"):
        TorqueMotor(K_t=0.0)
    with pytest.raises(ParamError, match="'motor.coulomb_friction'"):
        TorqueMotor(T_c=-1e-4)
    with pytest.raises(ParamError, match="'motor.resistance'"):
        TorqueMotor(R_w=math.nan)


def test_without_imbalance_the_motor_torque_spins_the_rotor_and_yaws_the_deck():
    """n = 0, eps = 0, friction off: the rotor's absolute acceleration is K_t i / J_z (theta'' +
    gamma'', theta being relative to the deck), and the reaction on the stator yaws the deck
    (gamma'' < 0, with X through the offset d); Y, Z, alpha, beta stay at rest.
    """
    params = DriveParams(n=0, eps=0.0)
    motor = TorqueMotor(b_v=0.0, T_c=0.0)
    sim = Simulation(params, 0.0, DT, spindle=motor, y0=initial_state(params, 0.0,
                                                                       deck0=(0.0,) * 6))
    sim.set_command(0.5)
    qdd = sim.accelerations()
    assert qdd[0] + qdd[6] == pytest.approx(motor.K_t * 0.5 / params.J_z, rel=1e-12)
    assert qdd[6] < 0.0 and qdd[1] != 0.0
    assert np.all(qdd[[2, 3, 4, 5]] == 0.0)
    assert sim.motor_torque == pytest.approx(motor.K_t * 0.5)


def test_a_torque_motor_starts_at_zero_current_and_switching_modes_resets_the_command():
    """Torque mode starts at 0 A; leaving it holds the present speed, and entering it again starts
    at 0 A until commanded."""
    params = DriveParams()
    sim = Simulation(params, 300.0, DT, spindle=TorqueMotor())
    assert sim.motor_current == 0.0 and sim.omega == 300.0
    sim.set_command(0.4)
    sim.set_spindle(ConstantSpeed())
    assert sim.omega_cmd == 300.0           # out of torque mode: hold the present speed
    sim.set_spindle(TorqueMotor())
    assert sim.motor_current == 0.0         # into torque mode: 0 A until commanded


def test_speed_modes_report_no_motor_current():
    """With a prescribed speed there is no motor: its current and torque read NaN, not a number
    that looks measured."""
    sim = Simulation(DriveParams(), 300.0, DT, spindle=ConstantSpeed())
    assert math.isnan(sim.motor_current) and math.isnan(sim.motor_torque)


# ---- ideal drive = speed mode ---------------------------------------------------------------

STIFF_RATE = 4000.0
"""Bandwidth [1/s] of the test's PI speed loop (rate * dt = 0.4, well inside RK4's and the
zero-order hold's stability)."""


def holding_torque(sim, S_speed):
    """Return the Q_theta that keeps theta'' = 0 at the current state.

    Q_theta that keeps theta'' = 0 at the current state: the theta row
    (kernels.torque.theta_row) at speed mode's accelerations (computed-torque feedforward of
    the ideal drive).
    """
    n = sim.params.n
    P = kernels.pack_params(sim.params)
    qdd = np.empty(7 + n)
    kernels.JIT.accel(sim.t, sim.y, n, P, S_speed, qdd, sim._solver)
    a, col = np.empty(6), np.empty(6)
    kernels.JIT.theta_row(sim.y, n, P, a, col)
    return a @ qdd[1:7] + sim.params.m * sim.params.R ** 2 * np.sum(qdd[7:])


def ideal_drive_errors(dt, duration=0.3):
    """Return the errors of torque mode with the ideal drive against speed mode.

    (max |omega error| [rad/s], max |theta error| [rad], max deck translation error / its range) of
    torque mode with the ideal drive against speed mode at constant omega, P3 with metal washers,
    both with steps dt. The drive: no current or voltage limit, no friction; its current, updated
    every step, is the computed torque that holds theta'' = 0 plus a PI speed loop of bandwidth
    STIFF_RATE * (1e-4 s / dt).
    """
    params = DriveParams().replace(c=0.66)
    omega = 2.7 * params.omega0
    nsteps = int(round(duration / dt))
    ref_y = Simulation(params, omega, dt, spindle=ConstantSpeed()).trajectory(nsteps, 1)
    S_speed = ConstantSpeed().pack(omega)
    motor = TorqueMotor(I_max=1e3, V_s=1e6, b_v=0.0, T_c=0.0)
    sim = Simulation(params, omega, dt, spindle=motor)
    inertia = params.J_z + params.M * params.eps ** 2 + params.n * params.m * params.R ** 2
    rate = STIFF_RATE * 1e-4 / dt
    kp = rate * inertia / motor.K_t
    ki = kp * rate / 4.0
    integral = 0.0
    ys = np.empty_like(ref_y)
    for k in range(nsteps):
        err = omega - sim.omega
        integral += err * dt
        sim.set_command(holding_torque(sim, S_speed) / motor.K_t + kp * err + ki * integral)
        sim.advance(1)
        ys[k] = sim.y
    X = slice(1, 4)
    return (np.max(np.abs(ys[:, 7 + params.n] - omega)), np.max(np.abs(ys[:, 0] - ref_y[:, 0])),
            np.max(np.abs(ys[:, X] - ref_y[:, X])) / np.ptp(ref_y[:, X]))


def test_torque_mode_with_an_ideal_drive_reproduces_constant_speed():
    """P3 (metal washers), 0.3 s: torque mode with an ideal drive (ideal_drive_errors) reproduces
    speed mode's constant-speed run. What remains is the discretisation of the drive: the current
    is held over each step while the torque that holds the speed varies with theta within it. It
    vanishes with the step: measured at dt = 1e-4 s |omega error| <= 1.410e-02 rad/s (1.7e-5
    relative), |theta error| <= 1.660e-05 rad, deck translations within 2.061e-05 of their range;
    at dt = 5e-5 s 2.045e-03 rad/s, 2.509e-06 rad, 2.943e-06 (and 2.672e-04, 3.819e-07, 3.870e-07
    at 2.5e-5 s): ~7x per halving. Bounds: 5e-5 relative, 5e-5 rad, 1e-4 at 1e-4 s, and each error
    at least 4x smaller at half the step.
    """
    omega = 2.7 * DriveParams().omega0
    coarse = ideal_drive_errors(DT)
    fine = ideal_drive_errors(DT / 2)
    for dt, (speed_err, theta_err, deck_err) in ((DT, coarse), (DT / 2, fine)):
        print(f'ideal drive, dt = {dt:g} s: |omega - omega_ref| <= {speed_err:.3e} rad/s, '
              f'|theta error| <= {theta_err:.3e} rad, deck translation error / range = '
              f'{deck_err:.3e}')
    speed_err, theta_err, deck_err = coarse
    assert speed_err < 5e-5 * omega
    assert theta_err < 5e-5
    assert deck_err < 1e-4
    assert all(c > 4.0 * f for c, f in zip(coarse, fine))


# ---- Sommerfeld effect ------------------------------------------------------------------------

WEAK_A = 0.05
STRONG_A = 0.2
"""Current limits [A] of the weak and the strong motor (K_t = 0.01 N m/A, Table 1 rotor,
rubber washers), each commanded at its limit from rest."""


def run_up(current_limit, duration, params=None, every=100):
    """omega(t) [rad/s] of a full-current run-up from 1 rad/s, sampled every ``every`` steps."""
    params = params or DriveParams()
    sim = Simulation(params, 1.0, DT, spindle=TorqueMotor(I_max=current_limit))
    sim.set_command(current_limit)
    y = sim.trajectory(int(round(duration / DT)), every)
    return np.arange(1, len(y) + 1) * every * DT, y[:, 7 + params.n]


@pytest.mark.slow
def test_a_weak_motor_is_captured_at_the_deck_resonance_and_a_strong_one_is_not():
    """Sommerfeld effect. The weak motor (0.05 A, 5e-4 N m) stays within 10 % of the translational
    natural frequency from 3 s to 5 s, although without any imbalance (eps = 0 and no balls: the
    balls at +-60 deg are an imbalance of the same size m R) the same motor passes 1.5 times that
    speed within 5 s; the strong one (0.2 A) is past twice the resonance within 2 s.
    """
    params = DriveParams()
    w_res = natural_frequencies(params)['Y']
    t, weak = run_up(WEAK_A, 5.0, params)
    late = weak[t >= 3.0]
    print(f'weak motor: omega in [{late.min():.1f}, {late.max():.1f}] rad/s for t in '
          f'[3, 5] s; resonance {w_res:.1f} rad/s')
    assert np.all(np.abs(late / w_res - 1.0) < 0.10)
    _, balanced = run_up(WEAK_A, 5.0, params.replace(eps=0.0, n=0))
    print(f'weak motor without imbalance: omega(5 s) = {balanced[-1]:.1f} rad/s')
    assert balanced[-1] > 1.5 * w_res
    t, strong = run_up(STRONG_A, 2.0, params)
    print(f'strong motor: omega(2 s) = {strong[-1]:.1f} rad/s')
    assert strong[-1] > 2.0 * w_res


# ---- scenarios ------------------------------------------------------------------------------

def test_the_shipped_torque_scenario_loads_a_weak_motor_and_current_commands():
    """runup_torque_weak loads a TorqueMotor limited to WEAK_A and one current command of WEAK_A at
    t = 0."""
    s = load_scenario('runup_torque_weak')
    assert isinstance(s.spindle, TorqueMotor) and s.spindle.I_max == WEAK_A
    assert s.commands == [CurrentCommand(0.0, WEAK_A)]


@pytest.mark.parametrize('spindle, field', [
    ({'model': 'torque', 'tau': 0.05}, 'scenario.spindle.tau'),
    ({'model': 'torque', 'motor': {'K_t': 0.01}}, 'scenario.spindle.motor.K_t'),
    ({'model': 'torque', 'motor': {'resistance': 0}}, 'scenario.spindle.motor.resistance'),
    ({'model': 'torque', 'commands': [{'t': 0, 'omega': 3}]},
     'scenario.spindle.commands[0].omega'),
    ({'model': 'torque', 'commands': [{'t': 0, 'current': float('nan')}]},
     'scenario.spindle.commands[0].current'),
])
def test_torque_scenario_schema_is_strict(tmp_path, spindle, field):
    """A speed-loop key, an unknown motor key, a zero resistance, a speed command or a NaN current
    in a torque scenario's spindle is a ParamError naming that field."""
    import yaml
    path = tmp_path / 'bad.yaml'
    path.write_text(yaml.safe_dump({'duration': 1.0, 'spindle': spindle}))
    with pytest.raises(ParamError, match=re.escape(f"'{field}'")):
        load_scenario(str(path))


def test_kernel_mode_constant_is_distinct_from_the_speed_profiles():
    """The kernels tell torque mode from every speed profile by its mode constant, and its packed
    profile has N_SPINDLE_TORQUE entries."""
    assert kernels.SPINDLE_TORQUE not in (kernels.SPINDLE_CONSTANT, kernels.SPINDLE_MOTOR,
                                          kernels.SPINDLE_RAMP)
    assert TorqueMotor().pack(0.0).shape == (kernels.N_SPINDLE_TORQUE,)


# ---- headless -------------------------------------------------------------------------------

def test_headless_torque_run_records_the_motor_torque_as_joint_effort(tmp_path):
    """abb-sim run of the shipped torque scenario: joint_states.effort = [K_t i, 0, 0], i = 0 at
    step 0 (the command of t = 0 applies from there on, as in speed mode), then the full 0.05 A
    (far below the voltage limit); the spindle accelerates.
    """
    from abb_ros.cli import main
    from abb_ros.io.bag.reader import read_bag
    out = tmp_path / 'bag'
    assert main(['run', '--scenario', 'runup_torque_weak', '--duration', '0.1', '--out',
                 str(out), '--no-progress']) == 0
    states = [m for _, m, _ in read_bag(out, ['joint_states'])]
    assert len(states) > 50
    assert list(states[0].effort) == [0.0, 0.0, 0.0]
    for m in states[1:]:
        assert list(m.effort) == [TorqueMotor().K_t * WEAK_A, 0.0, 0.0]
    assert states[-1].velocity[0] > states[0].velocity[0] + 5.0


def test_speed_loop_settings_on_a_torque_scenario_are_one_line_naming_them(tmp_path, capsys):
    """--set spindle.tau on a torque scenario ends abb-sim run with exit code 2 and one line naming
    spindle.tau and torque mode, and no bag is left."""
    from abb_ros.cli import main
    code = main(['run', '--scenario', 'runup_torque_weak', '--set', 'spindle.tau=0.1',
                 '--out', str(tmp_path / 'bag'), '--no-progress'])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "'spindle.tau'" in err[0] and 'torque' in err[0]
    assert not (tmp_path / 'bag').exists()

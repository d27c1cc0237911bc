"""The example controller spin_controller against the plant in lockstep over DDS: from rest to
the paper's P3 (metal washers) it balances the balls, with a lower peak rbar on the way than a
constant-acceleration ramp of the same duration; so it does in torque mode (a current command
from its speed loop, within the current limit); it holds only balanced speeds; an unknown mode
is refused at start-up."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from abb_ros.io.files.scenario import load_scenario
from abb_ros.model.stability import speed_bands
from abb_ros.nodes.spin_controller.node import SpinController
from abb_ros.testing.assertions import assert_balls_at_phi_star, peak, settling_time, time_in_bands
from abb_ros.testing.lockstep import drive_parameters

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[3]
P3 = load_scenario('p3')   # metal washers (c = 0.66), mbar = 0.03, wbar = 2.7
FROM_REST = {**drive_parameters(P3.params), 'spindle.initial_speed': 0.0}
RUN_S = 3.0                # the balls are settled well before (about 2 s)


def controller_in(plant, **parameters):
    from rclpy.parameter import Parameter
    overrides = plant.shared_parameters() + [Parameter(k, value=v)
                                             for k, v in parameters.items()]
    node = SpinController(context=plant.context, parameter_overrides=overrides)
    plant.add_node(node)
    return node


def reach_time(trace, omega: float) -> float:
    """First time the spindle is within 0.1 % of omega."""
    return float(trace.t[np.argmax(trace.omega >= 0.999 * omega)])


@pytest.mark.slow
def test_run_up_from_rest_to_p3_balances_the_balls_with_a_lower_peak_rbar_than_a_ramp(
        lockstep_plant):
    target = P3.omega
    plant = lockstep_plant(FROM_REST, analysis=True)
    controller = controller_in(plant, target_speed=target)
    plant.run_for(RUN_S)
    run = plant.trace()
    assert run.omega[-1] == pytest.approx(target, rel=1e-6)
    assert_balls_at_phi_star(run.phi[-1], P3.params, 1.0)
    assert run.rbar[-1] < 1e-5, run.rbar[-1]
    # The analysis agrees that the hold speed is balanced.
    plant.spin_until(lambda: controller.margin > 0.0, 'a positive stability/margin')

    duration = reach_time(run, target)
    plant.close()
    ramp = lockstep_plant(FROM_REST)
    accel = target / duration
    for k in range(round((duration + 0.5) / ramp.period_s)):
        ramp.command(min(target, accel * k * ramp.period_s))
        ramp.advance(1)
    ramped = ramp.trace()
    peak_controller = peak(run.t, run.rbar, t_to=duration)
    peak_ramp = peak(ramped.t, ramped.rbar, t_to=reach_time(ramped, target))
    bands = speed_bands.speed_table(P3.params, 1500.0).bands
    print(f'\nrun-up 0 -> {target:.1f} rad/s in {duration:.3f} s: peak rbar {peak_controller:.4g} '
          f'(spin_controller) vs {peak_ramp:.4g} (constant {accel:.0f} rad/s^2 ramp); time in '
          f'unbalanced bands {time_in_bands(run.t, run.omega, bands):.3f} s vs '
          f'{time_in_bands(ramped.t, ramped.omega, bands):.3f} s; rbar < 1e-5 from '
          f't = {settling_time(run.t, run.rbar, 0.0, 1e-5):.3f} s; final rbar '
          f'{run.rbar[-1]:.3g}')
    assert peak_controller < peak_ramp


def test_a_target_inside_an_unbalanced_band_is_held_at_the_nearest_balanced_speed(
        lockstep_plant):
    plant = lockstep_plant(FROM_REST)
    bands = speed_bands.speed_table(P3.params, 1500.0).bands
    band = next(b for b in bands if b.lo > 0)  # the first band above the resonance
    # With an outer PI loop on top of the drive's (the gains are in the command).
    controller = controller_in(plant, target_speed=(band.lo + band.hi) / 2, kp=0.5, ki=2.0)
    guard = 0.1 * P3.params.omega0
    assert controller.hold in (pytest.approx(band.lo - guard), pytest.approx(band.hi + guard))
    plant.run_for(1.5)
    run = plant.trace()
    assert run.omega[-1] == pytest.approx(controller.hold, rel=1e-2)
    # From rest, the band below the resonance is crossed at the drive's limit (2000 rad/s^2).
    assert time_in_bands(run.t, run.omega, bands) < 0.3


@pytest.mark.slow
def test_a_mode_other_than_speed_or_torque_exits_with_code_2_and_one_line_naming_it():
    result = subprocess.run(
        [sys.executable, '-m', 'abb_ros.nodes.spin_controller', '--ros-args', '-p',
         'mode:=current'], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "'mode'" in lines[0] and "'current'" in lines[0], lines
    assert 'speed' in lines[0] and 'torque' in lines[0]


@pytest.mark.slow
def test_torque_mode_run_up_from_rest_to_p3_balances_the_balls_within_the_current_limit(
        lockstep_plant):
    # The simulator's default motor (docs/torque_mode.md): K_t 0.01 N m/A, 1 A, 12 V.
    target = P3.omega
    plant = lockstep_plant({**FROM_REST, 'spindle.mode': 'torque'}, analysis=True)
    controller = controller_in(plant, mode='torque', target_speed=target)
    assert controller.loop.motor == plant.sim.settings.motor
    plant.run_for(RUN_S)
    run = plant.trace()
    assert run.omega[-1] == pytest.approx(target, rel=1e-4)
    assert_balls_at_phi_star(run.phi[-1], P3.params, 1.0)
    assert run.rbar[-1] < 1e-5, run.rbar[-1]
    limit = plant.sim.settings.motor.I_max
    assert np.all(np.abs(run.current_cmd) <= limit)
    plant.spin_until(lambda: controller.margin > 0.0, 'a positive stability/margin')
    duration = reach_time(run, target)
    bands = speed_bands.speed_table(P3.params, 1500.0).bands
    print(f'\ntorque mode: run-up 0 -> {target:.1f} rad/s in {duration:.3f} s: peak rbar '
          f'{peak(run.t, run.rbar, t_to=duration):.4g}; time in unbalanced bands '
          f'{time_in_bands(run.t, run.omega, bands):.3f} s; at the {limit:g} A limit '
          f'{np.sum(np.abs(run.current_cmd) >= limit) * plant.period_s:.3f} s; overshoot '
          f'{np.max(run.omega) - target:.3g} rad/s; rbar < 1e-5 from '
          f't = {settling_time(run.t, run.rbar, 0.0, 1e-5):.3f} s; final rbar '
          f'{run.rbar[-1]:.3g}, speed error {run.omega[-1] - target:.3g} rad/s')


@pytest.mark.slow
def test_a_new_target_at_run_time_is_reached_jumping_down_over_the_bands(lockstep_plant):
    from rclpy.parameter import Parameter
    plant = lockstep_plant(drive_parameters(P3.params))  # starts at P3's 811.2 rad/s
    controller = controller_in(plant)
    plant.run_for(0.2)
    assert controller.hold == pytest.approx(P3.omega)
    assert controller.set_parameters([Parameter('target_speed', value=450.0)])[0].successful
    plant.run_for(1.0)
    run = plant.trace()
    assert run.omega[-1] == pytest.approx(450.0, abs=1e-3)
    bands = plant.bands()
    assert [b for b in bands if 450.0 < b.lo < P3.omega]  # bands on the way down ...
    # ... crossed at the drive's 2000 rad/s^2: 90 rad/s of bands, about 45 ms.
    assert time_in_bands(run.t, run.omega, bands) < 0.1
    # The command never asked for a speed inside a band.
    assert not [w for w in run.omega_cmd if any(b.lo <= w <= b.hi for b in bands)]

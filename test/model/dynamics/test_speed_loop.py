"""The torque-mode speed loop on a rigid rotor without ROS.

The loop (abb_ros/nodes/spin_controller/speed_loop.py) tracks a ramp, never asks for more
current than the drive delivers, and does not wind up."""

import numpy as np
import pytest

from abb_ros.io.files.scenario import load_scenario
from abb_ros.model.dynamics.spindle import TorqueMotor
from abb_ros.nodes.spin_controller.speed_loop import SpeedLoop, rotor_inertia

P3 = load_scenario('p3').params
J = rotor_inertia(P3)
DT = 1.0 / 200.0          # the lockstep harness' control period
SUBSTEPS = 50


def run(loop: SpeedLoop, reference, seconds: float, inertia: float = J,
        load: float = 0.0):
    """Rigid rotor inertia omega' = K_t i(omega) - friction(omega) - load, the loop's current
    held over each period (zero-order hold, as the lockstep plant applies it); returns the
    times, speeds, commands and the limits at each command, one row per period."""
    m = loop.motor
    omega = 0.0
    rows = []
    for k in range(round(seconds / DT)):
        t = k * DT
        ref = reference(t)
        alpha = (reference(t + DT) - ref) / DT   # as the controller: one period ahead
        cmd = loop.step(ref, alpha, omega, DT)
        rows.append((t, omega, ref, cmd, *loop.limits(omega)))
        for _ in range(SUBSTEPS):
            torque = m.K_t * m.current(omega, cmd) - loop.friction(omega) - load
            omega += torque / inertia * (DT / SUBSTEPS)
    return np.array(rows).T


def ramp(accel: float, hold: float):
    return lambda t: min(accel * t, hold)


def test_rotor_inertia_is_the_theta_rows_coefficient_j_z_plus_m_eps2_plus_n_m_r2():
    assert J == pytest.approx(P3.J_z + P3.M * P3.eps ** 2 + 2 * P3.m * P3.R ** 2, rel=1e-15)
    assert J == pytest.approx(3.2826e-6, rel=1e-4)   # P3: m = 0.03 M


def test_a_500_rad_s2_ramp_is_tracked_within_0_01_rad_s_despite_a_20_percent_heavier_rotor():
    loop = SpeedLoop(TorqueMotor(), J, bandwidth=60.0)
    t, omega, ref, cmd, lo, hi = run(loop, ramp(500.0, 800.0), 2.5, inertia=1.2 * J,
                                     load=2e-4)
    on_ramp = (t > 0.5) & (t < 1.5)
    settled = t > 2.2
    print(f'\nramp error {np.max(np.abs(ref - omega)[on_ramp]):.3g} rad/s on the ramp, '
          f'{np.max(np.abs(ref - omega)[settled]):.3g} rad/s holding; peak current '
          f'{np.max(cmd):.3f} A')
    assert np.max(np.abs(ref - omega)[on_ramp]) < 0.01
    assert np.max(np.abs(ref - omega)[settled]) < 1e-3
    assert np.all(cmd < hi + 1e-15) and np.all(cmd > lo - 1e-15)


def test_the_command_stays_within_the_current_and_supply_limits():
    # A reference far beyond the motor: 1 A gives about 3200 rad/s^2; the 12 V supply caps
    # the current above (12 - 2 * 0.3) / 0.01 = 1140 rad/s.
    motor = TorqueMotor(I_max=0.3)
    loop = SpeedLoop(motor, J, bandwidth=60.0)
    t, omega, ref, cmd, lo, hi = run(loop, ramp(1e5, 1500.0), 2.0)
    assert np.all(cmd <= hi) and np.all(cmd >= lo)
    assert np.max(cmd) == pytest.approx(0.3)
    # At the top the supply, not I_max, is the limit: the drive's no-load speed.
    assert hi[-1] < 0.3 and omega[-1] < 1200.0
    assert cmd[-1] == pytest.approx(hi[-1])


class WindingUp(SpeedLoop):
    """The same loop with an integral that always integrates (no anti-windup)."""

    def step(self, omega_ref, alpha_ref, omega, dt):
        error = omega_ref - omega
        self.integral += self.ki * error * dt
        lo, hi = self.limits(omega)
        wanted = self.feedforward(alpha_ref, omega) + self.kp * error + self.integral
        return min(max(wanted, lo), hi)


def test_after_a_long_saturated_run_up_the_speed_does_not_overshoot_the_hold():
    # The reference jumps to 800 rad/s at once (as over an unbalanced band): the current is
    # at its 1 A limit for a quarter of a second with a large error, yet the integral does
    # not grow, so the speed arrives at the hold without the windup overshoot (what remains
    # is the PI zero's, a few rad/s).
    overshoots = {}
    for kind in (SpeedLoop, WindingUp):
        loop = kind(TorqueMotor(), J, bandwidth=60.0)
        t, omega, ref, cmd, lo, hi = run(loop, lambda _t: 800.0, 1.5)
        saturated = np.sum(cmd >= hi - 1e-12) * DT
        overshoots[kind] = np.max(omega) - 800.0
        print(f'\n{kind.__name__}: at the limit {saturated:.3f} s, overshoot '
              f'{overshoots[kind]:.4g} rad/s, final error {800.0 - omega[-1]:.2g} rad/s')
        assert saturated > 0.2
        assert abs(omega[-1] - 800.0) < 1e-2
    assert overshoots[SpeedLoop] < 10.0
    assert overshoots[WindingUp] > 100.0

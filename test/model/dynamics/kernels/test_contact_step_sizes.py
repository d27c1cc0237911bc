"""The contact step's accuracy over the guaranteed steps and approach speeds.

The guaranteed range: integration steps from 1e-5 to 2e-4 s, approach speeds from 0.001 to 0.5
m/s, in both spindle modes (speed mode: the multirate step, kernels.multirate.mis_contact_step;
torque mode: whole-system RK4 sub-steps).

The head-on collision on the clamped race (test_contact_multirate.head_on) is elastic: its rebound
speeds must agree with a fine run (2.5e-7 s) to the documented accuracy, 1e-5 m/s or 7.8e-5 of the
speed, whichever is looser, and its kinetic energy must come back to the same accuracy (as the
speed it stands for). docs/ball_size_contact_rolling.md, Impacts at any step.
"""

import numpy as np
import pytest
from test_contact_multirate import head_on

from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.equations import solver_buffers
from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.dynamics.kernels.layout import STAT_REFINED, W_STATS
from abb_ros.model.dynamics.spindle import ConstantSpeed, TorqueMotor

SPEEDS = (0.001, 0.01, 0.05, 0.5)
STEPS = (1e-5, 3e-5, 1e-4, 2e-4)
ONSETS = 8
"""Contact onsets per step, at (k + 1/2) / ONSETS of the first step."""
FINE = 2.5e-7
"""The reference's step [s] (omega_c h <= 0.07 at 0.5 m/s, 0.02 at 0.01 m/s)."""
DURATION = 2e-3
"""Long enough for the balls to part at every speed (contact lasts 20-70 us)."""


def tolerance(speed):
    """Return the documented rebound accuracy [m/s]: 1e-5 m/s or 7.8e-5 of the speed.

    The documented rebound accuracy [m/s]: 1e-5 m/s or 7.8e-5 of the speed.
    """
    return max(kernels.CONTACT_IMPACT_SPEED, speed) * 7.8e-5


def speeds_after(params, y0, dt, spindle):
    """Return the balls' speeds along the race after DURATION at steps of dt, and more.

    The balls' speeds along the race [m/s] (race-fixed, and absolute: with the rotor's rate, which
    is free in torque mode) after DURATION at steps of dt; the refined steps.
    """
    sim = Simulation(params, 0.0, dt=dt, spindle=spindle, y0=y0)
    if isinstance(spindle, TorqueMotor):
        sim.set_command(0.0)
    sim.advance(int(round(DURATION / dt)))
    return sim.phi_rates * params.R, (sim.omega + sim.phi_rates) * params.R, sim.refined_steps


@pytest.mark.parametrize('dt', STEPS)
@pytest.mark.parametrize('speed', SPEEDS)
@pytest.mark.slow
def test_an_elastic_impact_rebounds_and_keeps_its_energy_at_every_step_and_speed(speed, dt):
    """Rebound speeds against the fine run and the energy's error (as a speed, sqrt of twice the
    kinetic energy over the mass, minus the approach speed) within the documented accuracy, at
    ONSETS onsets, in speed and torque mode. Measured worst cells (rebound, of the tolerance): 0.5
    m/s at 3e-5 s 1.98e-5 of 3.9e-5 m/s (speed mode), 1.76e-5 at 1e-5 s (torque mode); before the
    step across an impact's peak was checked (15af775) 5.7e-4 m/s at 0.05 m/s and 1e-5 s, and
    torque mode's impacts at omega_c h 0.3 up to 5.2e-5 m/s at 0.5 m/s.
    """
    worst = {}
    for k in range(ONSETS):
        params, y0 = head_on(speed, (k + 0.5) / ONSETS, dt)
        ref = speeds_after(params, y0, FINE, ConstantSpeed())[0]
        for mode, spindle in (('speed', ConstantSpeed()), ('torque', TorqueMotor())):
            rebound, absolute, refined = speeds_after(params, y0, dt, spindle)
            assert refined > 0                          # the contact was sub-stepped or retaken
            errors = (np.abs(rebound - ref).max(),
                      abs(np.sqrt((absolute ** 2).sum()) - speed))
            worst[mode] = np.maximum(worst.get(mode, 0.0), errors)
    print(f'{speed} m/s at {dt:g} s, worst of {ONSETS} onsets (rebound, energy as a speed) '
          f'[m/s]: ' + ', '.join(f'{mode} {e[0]:.2e} {e[1]:.2e}' for mode, e in worst.items()))
    for mode, errors in worst.items():
        assert errors.max() < tolerance(speed), mode


@pytest.mark.parametrize('torque', [False, True])
def test_the_step_across_an_impacts_peak_is_taken_again(torque):
    """0.05 m/s at 1e-5 s, the contact beginning at 15/16 of the first step: the third step starts
    before the peak and ends after it. Its overlap and energies look resting at both ends (the
    overlap 4.6e-7 -> 4.9e-7 m, more static than kinetic 'energy'), with omega_c dt ~ 1.8, taken
    whole (one RK4 step); but the rate turns round: it changes by about what the contact force
    alone, unbalanced, gives over the step (resting_misjudged: more than CONTACT_REST_IMBALANCE of
    it), so the step is taken again as an impact.
    """
    dt = 1e-5
    params, y0 = head_on(0.05, 15 / 16, dt)
    n = 2
    P = kernels.pack_params(params)
    K = kernels.JIT
    spindle = TorqueMotor() if torque else ConstantSpeed()
    sim = Simulation(params, 0.0, dt=dt, spindle=spindle, y0=y0)
    sim.advance(2)
    start = sim.y.copy()
    sub, impact, resting = K.contact_regimes(start, n, P, dt, False)
    assert (sub, impact, resting) == (1, False, True)
    whole = start.copy()
    K.rk4_substep(sim.t, dt, whole, n, P, sim.spindle.pack(0.0), kernels.stage_buffers(n),
                  solver_buffers(n))
    Kc, mb, _ = K.contact_scales(P)
    ends = [K.pair_state(y, n, P, 0, 1)[:2] for y in (start, whole)]
    for delta, rate in ends:
        static, kinetic = K.pair_energies(delta, rate, Kc, mb)
        assert static > kinetic
    assert 0.5 < ends[1][0] / ends[0][0] < 2.0
    imbalance = abs(ends[1][1] - ends[0][1]) * mb / (2 * Kc * ends[0][0] ** 1.5 * dt)
    print(f'overlap {ends[0][0]:.3e} -> {ends[1][0]:.3e} m, rate {ends[0][1]:+.3e} -> '
          f'{ends[1][1]:+.3e} m/s: {imbalance:.2f} of the unbalanced contact force')
    assert imbalance > 0.5 > kernels.CONTACT_REST_IMBALANCE
    assert K.resting_misjudged(start, whole, n, P, dt)
    refined = sim.refined_steps
    sim.advance(1)
    assert sim.refined_steps == refined + 1             # taken again, in sub-steps
    assert not np.array_equal(sim.y, whole)


@pytest.mark.parametrize('torque', [False, True])
def test_the_python_twin_takes_the_same_steps_at_a_fine_step(torque):
    """The collision of the test above, its first 6 steps (the peak's taken again) by kernels.PY
    and kernels.JIT: the same state, bit for bit.
    """
    dt = 1e-5
    params, y0 = head_on(0.05, 15 / 16, dt)
    n = params.n
    P = kernels.pack_params(params)
    S = (TorqueMotor() if torque else ConstantSpeed()).pack(0.0)
    out = []
    for kern in (kernels.JIT, kernels.PY):
        y = y0.copy()
        work = kernels.make_work(n)
        assert kern.advance(y, 0.0, dt, 0, 6, P, S, work)[0] == 6
        out.append((y, work[W_STATS, STAT_REFINED]))
    assert out[0][1] == out[1][1] >= 3
    np.testing.assert_array_equal(out[1][0], out[0][0])


def test_a_step_outside_the_verified_range_is_said_not_refused():
    """With contact on, a step outside 1e-5..2e-4 s runs and says so (summary and node /diagnostics
    use contact_step_note); without contact, or inside the range, nothing.
    """
    from abb_ros.model.dynamics.integrate import contact_step_note
    from abb_ros.model.parameters.params import DriveParams
    touching = DriveParams(n=3, r_ball=0.0023, contact_E=2e11)
    assert contact_step_note(touching, 1e-4) == ''
    assert contact_step_note(touching, 1e-5) == '' and contact_step_note(touching, 2e-4) == ''
    assert '5e-06 s outside 1e-05..0.0002 s' in contact_step_note(touching, 5e-6)
    assert 'outside' in contact_step_note(touching, 5e-4)
    assert contact_step_note(DriveParams(n=3), 5e-4) == ''

"""Ball-ball contact, rolling resistance with stick, and their energy bookkeeping.

"Deck coupling absent": the clamped-race configuration of these tests gives the deck 1e9 kg
and 1e9 kg m^2 (M_P, J_Px, J_Py, J_Pz) and the rotor no eccentricity, so the balls' forces move
the deck by ~1e-13 of their own accelerations: the balls run on a fixed race spinning at the
spindle speed (the rotor keeps its own inertia: the motor's reaction torque J_z theta'' then
turns the deck by nothing either). docs/ball_size_contact_rolling.md.
"""

import math

import numpy as np
import pytest
from race_ledger import collision_state, race_energy_ledger

from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.equations import solver_buffers
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.dynamics.spindle import ConstantSpeed, Ramp
from abb_ros.model.parameters.ball_materials import STEEL_E, clamped_race
from abb_ros.model.parameters.params import DriveParams, ParamError

M_BALL = 0.78e-3
"""P1/P3 ball mass (mbar = 0.03) [kg]; steel radius 2.873 mm."""


def clamped(n=2, **kw):
    """Steel balls on a race whose deck cannot move (see the module docstring)."""
    return clamped_race(n, M_BALL, **kw)


def momentum(params, y):
    """Momentum along the race of the balls relative to it, sum m_eff R^2 phi_i' [kg m^2/s]."""
    N = 7 + params.n
    m_eff = params.m * (1.4 if params.ball_rotation else 1.0)
    return m_eff * params.R ** 2 * y[N + 7:].sum()


@pytest.mark.parametrize('rotation', [0, 1])
def test_head_on_collision_conserves_momentum_along_the_race(rotation):
    """Elastic Hertz impact (contact_damping = 0) at 0.05 m/s at the default 10 kHz step: the step
    is refined automatically (sub-steps), the momentum along the race is conserved to 1e-9 relative
    and the equal balls exchange their velocities (to 1e-3).
    """
    params = clamped(ball_rotation=rotation)
    y0 = collision_state(params, 0.0, gap=1e-6, speed=0.05)
    sim = Simulation(params, 0.0, spindle=ConstantSpeed(), y0=y0)
    sim.advance(20)                                           # 2 ms: the contact lasts ~30 us
    p0, p1 = momentum(params, y0), momentum(params, sim.y)
    print(f'momentum before {p0:.15e}, after {p1:.15e}, relative change {abs(p1 - p0) / p0:.2e}; '
          f'refined steps {sim.refined_steps}, max sub-steps {sim.max_substeps}')
    assert abs(p1 - p0) < 1e-9 * abs(p0)
    assert sim.refined_steps >= 1 and sim.max_substeps > 10
    rates = sim.phi_rates * params.R
    assert abs(rates[0]) < 1e-3 * 0.05 and abs(rates[1] - 0.05) < 1e-3 * 0.05
    gap = 2 * params.R * math.sin((sim.phi[1] - sim.phi[0]) / 2) - 2 * params.r_ball
    assert gap > 0                                            # they parted again


def test_contact_stiffness_is_hertz_for_two_equal_steel_balls():
    """K = 4/3 E* sqrt(r/2), E* = E / (2 (1 - nu^2)): 5.55e9 N/m^1.5 for r = 2.873 mm."""
    params = clamped()
    K = kernels.JIT.contact_stiffness(kernels.pack_params(params))
    r = params.r_ball
    assert K == pytest.approx(4 / 3 * STEEL_E / (2 * (1 - 0.09)) * math.sqrt(r / 2), rel=1e-14)
    assert 5.5e9 < K < 5.6e9


def _ramp_run(fraction):
    """Accelerate the spindle under one ball at rest; return (sim, threshold).

    One ball at rest on the race at omega = 811 rad/s; the spindle accelerates at ``fraction`` of
    the stick threshold mu omega^2 / r for 50 ms. Returns (sim, threshold).
    """
    mu = 1e-6
    params = clamped(n=1, contact_E=0.0, rolling_mu=mu)
    omega = 811.0
    threshold = mu * omega ** 2 / params.r_ball                      # rad/s^2
    y0 = initial_state(params, omega, phi0=[0.3], deck0=(0.0,) * 6)
    sim = Simulation(params, omega, spindle=Ramp(0.0, 0.05, fraction * threshold), y0=y0)
    sim.advance(500)
    return sim, threshold


def test_ball_at_rest_sticks_while_the_drive_is_below_the_rolling_threshold():
    """Karnopp stick: a spindle acceleration of 0.8 of the threshold moves the ball not at all
    relative to the race (a tanh law would creep at a rate set by its regularisation).
    """
    sim, _ = _ramp_run(0.8)
    assert abs(sim.phi_rates[0]) < 1e-12
    assert abs(sim.phi[0] - 0.3) < 1e-12


def test_ball_slips_above_the_rolling_threshold_with_the_coulomb_deceleration():
    """At 1.25 of the threshold (at the start speed) the race runs away from the ball: phi'' =
    -(theta'' - mu omega^2 / r) relative to the race, to the 3 % by which the threshold grows with
    omega over the ramp.
    """
    sim, threshold = _ramp_run(1.25)
    expected = -(1.25 - 1.0) * threshold * 0.05
    assert sim.phi_rates[0] < 0
    assert sim.phi_rates[0] == pytest.approx(expected, rel=0.15)


def test_contact_and_rolling_need_a_ball_radius_and_balls_must_fit():
    """Contact or rolling resistance without a ball radius, balls too big for the race, or a
    ball_rotation other than 0 or 1 is a ParamError naming the parameter."""
    with pytest.raises(ParamError, match="'r_ball'.*contact_E"):
        DriveParams(contact_E=2e11)
    with pytest.raises(ParamError, match="'r_ball'.*rolling_mu"):
        DriveParams(rolling_mu=1e-6)
    with pytest.raises(ParamError, match="'r_ball'.*do not fit"):
        DriveParams(n=10, r_ball=0.005, contact_E=2e11)
    with pytest.raises(ParamError, match="'ball_rotation'"):
        DriveParams(ball_rotation=0.5)


@pytest.mark.slow
def test_energy_of_a_collision_with_contact_damping_and_rolling_resistance_closes():
    """Clamped race at P3's speed (811 rad/s): ball 1 hits ball 2 at 0.05 m/s with Hunt-Crossley
    damping (chi = 0.5 s/m), ball drag D and rolling resistance (mu = 1e-5 m, both balls end caught
    in the stick band). Input work of the spindle = change of kinetic + contact potential energy +
    energy dissipated (drag, contact damping, rolling), closed to 1e-6 of the input work.

    The spindle's torque is theta's row of Lagrange's equations: with the race clamped and theta''
    = 0 it is d/dt sum m R^2 (theta' + phi_i'), so the input work is theta' times the change of
    that angular momentum; the dissipated powers are integrated by Simpson's rule over every step
    of 0.1 us (the contact lasts ~30 us).
    """
    params = clamped(rolling_mu=1e-5, contact_damping=0.5, D=5e-6)
    omega = 811.0
    dt = 1e-7
    y0 = collision_state(params, omega, gap=1e-6, speed=0.05)
    sim = Simulation(params, omega, dt=dt, spindle=ConstantSpeed(), y0=y0)
    ys = np.concatenate([y0[None], sim.trajectory(40000, 1)])   # 4 ms: both balls stop
    led = race_energy_ledger(params, omega, ys, dt)
    w_in, w_diss, residual = led['input'][-1], led['dissipated'][-1], led['residual'][-1]
    print(f'input {w_in:.9e} J, kinetic {led["kinetic"][-1]:.9e} J, potential '
          f'{led["potential"][-1]:.3e} J, dissipated {w_diss:.9e} J, residual {residual:.3e} J '
          f'({abs(residual / w_in):.2e} of the input, {abs(residual / w_diss):.2e} of the '
          'dissipated)')
    # both caught in the stick band (2.3 rad/s here: Qmax / (m R^2) STICK_TIME), dying out
    assert np.all(np.abs(ys[-1, 9 + 7:]) < 0.1)
    assert w_diss > 0 and abs(residual) < 1e-6 * abs(w_in)


@pytest.mark.slow
def test_slip_to_stick_switch_is_located_at_the_instant_the_ball_enters_the_stick_band():
    """Event-located Coulomb switching. One ball on the clamped race at 811 rad/s, slipping
    forwards at 2 rad/s, no drag: psi'' = -c psi'^2 (c = mu / r), so 1/psi' = 1/psi'_0 + c t, until
    phi' = psi' - omega meets the band c psi'^2 STICK_TIME (~7.7 ms, inside a step of 0.1 ms); then
    it sticks and phi' = phi'(t*) exp(-(t - t*) / STICK_TIME). The integrator locates the switch at
    the analytic instant (to 1e-12 s) and the stuck decay runs from it (RK4's decay of the stuck
    law from the located instant, to 1e-9). Without another force the stuck ball's force at the
    band's floor is exactly Qmax: the state just inside counts as broken free, which holds for
    ~1e-15 s, so there may be two switches at that instant, slip -> broken free -> stuck.
    """
    mu, omega, rate0, dt = 1e-6, 811.0, 2.0, 1e-4
    params = clamped(n=1, contact_E=0.0, rolling_mu=mu)
    c, tau = mu / params.r_ball, kernels.STICK_TIME
    band_psi = (1 - math.sqrt(1 - 4 * c * tau * omega)) / (2 * c * tau)
    t_star = (1 / band_psi - 1 / (omega + rate0)) / c
    y = initial_state(params, omega, phi0=[0.3], deck0=(0.0,) * 6)
    y[8 + 7] = rate0
    P, S = kernels.pack_params(params), ConstantSpeed().pack(omega)
    stages = kernels.stage_buffers(1)
    events, cache = np.empty((kernels.MAX_SWITCHES, 1 + 1 + y.size)), np.zeros((3, y.size))
    bufs = solver_buffers(1)
    located = []
    steps = 150
    for s in range(steps):
        k = kernels.JIT.rolling_substep(s * dt, dt, y, 1, P, S, stages, bufs, events, cache)
        located += [(s * dt + events[i, 0], events[i, 1], events[i, 2 + 8 + 7])
                    for i in range(k)]
    print(f'analytic switch {t_star:.15f} s; located {located}')
    assert 1 <= len(located) <= 2
    t_switch, regime, rate_switch = located[-1]
    assert regime == 0.0                                                   # stuck
    assert all(abs(t - t_star) < 1e-12 for t, _, _ in located)
    assert rate_switch == pytest.approx(band_psi - omega, rel=1e-9)
    # stuck: phi'' = -phi' / STICK_TIME, which RK4 multiplies by its polynomial of -h / tau,
    # from the switch to the end of its step, then step by step
    rk4 = np.polynomial.Polynomial([1, 1, 1 / 2, 1 / 6, 1 / 24])
    after = (t_switch // dt + 1) * dt - t_switch
    decay = rate_switch * rk4(-after / tau) * rk4(-dt / tau) ** (steps - t_switch // dt - 1)
    assert y[8 + 7] == pytest.approx(decay, rel=1e-9)

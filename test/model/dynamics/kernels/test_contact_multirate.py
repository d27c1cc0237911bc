"""The multirate contact step (kernels.multirate.mis_contact_step).

docs/ball_size_contact_rolling.md states its accuracy.

Its energy closure over a collision is in test_contact_rolling_energy; its momentum along the
race in test_contact_rolling (the head-on collision runs through it).
"""

import functools

import numpy as np
import pytest
from race_ledger import collision_state

from abb_ros.io.files.scenario import load_scenario
from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.equations import solver_buffers
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.dynamics.kernels.layout import STAT_REFINED, W_STATS
from abb_ros.model.dynamics.spindle import ConstantSpeed, TorqueMotor
from abb_ros.model.parameters.ball_materials import clamped_race, with_steel_balls
from abb_ros.model.parameters.params import DriveParams

K = kernels.JIT


def p3_state(params, kick=30.0):
    """Return the P3 state of a collision, the deck displaced and moving, and its S.

    P3, balls at 30 and 53 deg, ball 1 thrown at ``kick`` rad/s, the deck displaced and moving (so
    that every rate-dependent term of the deck rows is non-zero).
    """
    scenario = load_scenario('p3')
    N = 7 + params.n
    y = initial_state(params, scenario.omega, phi0=np.radians((30.0, 53.0)),
                      deck0=(1e-4, -2e-4, 5e-5, 2e-3, -1e-3, 3e-3))
    y[N + 1:N + 7] = (0.01, -0.02, 0.005, 0.3, -0.2, 0.4)
    y[N + 7] = kick
    return y, ConstantSpeed().pack(scenario.omega)


@pytest.mark.parametrize('rotation', [False, True])
def test_velocity_coupling_is_the_derivative_of_the_accelerations_in_the_ball_rates(rotation):
    """Jv (kernels.multirate.velocity_coupling, the linear part of the rate-dependent terms that
    the multirate step moves into its fast part) equals d q'' / d phi_b' of the full model
    (central differences: q'' is quadratic in the rates, so they are exact up to round-off).
    """
    params = with_steel_balls(load_scenario('p3').params, rotation=rotation)
    n, N = params.n, 7 + params.n
    P = kernels.pack_params(params)
    y, S = p3_state(params)
    solver = solver_buffers(n)
    qdd = np.empty(N)
    K.accel(0.0, y, n, P, S, qdd, solver)
    Jv = np.empty((N, n))
    K.velocity_coupling(y, n, P, 1.0 / K.ball_inertia(P), np.linalg.inv(solver.A), solver.W,
                        solver.B, Jv)
    step = 1.0
    for b in range(n):
        rows = []
        for sign in (1.0, -1.0):
            yb = y.copy()
            yb[N + 7 + b] += sign * step
            q = np.empty(N)
            K.accel(0.0, yb, n, P, S, q, solver_buffers(n))
            rows.append(q)
        fd = (rows[0] - rows[1]) / (2.0 * step)
        np.testing.assert_allclose(Jv[:, b], fd, rtol=1e-7, atol=1e-9 * np.abs(fd).max())
    assert np.abs(Jv[1:7]).max() > 0.0                  # the deck feels the balls' rates


def test_multirate_step_of_an_impact_agrees_with_fine_rk4_sub_steps():
    """The step in which ball 1 (30 rad/s) hits ball 2, P3: the multirate step and RK4 sub-steps of
    the whole system, both at the multirate step's sub-steps, differ from RK4 at 16 times as many
    by the same order (the impact's resolution; measured: ball rates 1.2e-4 and 1.6e-4 rad/s), the
    multirate step's deck rates by 2.5e-6 (its deck inverse is the step's start's).
    """
    params = with_steel_balls(load_scenario('p3').params, rotation=True)
    n, N = params.n, 7 + params.n
    P = kernels.pack_params(params)
    y, S = p3_state(params)
    dt = 1e-4
    bufs = solver_buffers(n)
    stages = kernels.stage_buffers(n)

    def rk4(y, t, sub):
        for j in range(sub):
            K.rk4_substep(t + j * dt / sub, dt / sub, y, n, P, S, stages, bufs)

    s = 0
    while True:                     # up to the step in which ball 1 loses most of its rate
        sub = K.mis_substeps(y, n, P, dt)
        ref = y.copy()
        rk4(ref, s * dt, 16 * K.contact_substeps(y, n, P, dt))
        if ref[N + 7] < 10.0:
            break
        y = ref
        s += 1
    assert K.contact_regime(y, n, P, dt)[1] and sub > 1
    coarse, mis = y.copy(), y.copy()
    rk4(coarse, s * dt, sub)
    K.mis_contact_step(s * dt, dt, mis, n, P, S, sub, np.empty((0, 2 * N)), bufs)
    ball_rk4 = np.abs(coarse - ref)[N + 7:].max()
    ball_mis = np.abs(mis - ref)[N + 7:].max()
    deck_mis = np.abs(mis - ref)[N + 1:N + 7].max()
    print(f'balls: multirate {ball_mis:.2e}, rk4 {ball_rk4:.2e}; deck: multirate {deck_mis:.2e}')
    assert ball_mis < 5 * max(ball_rk4, 1e-4)
    assert deck_mis < 1e-5
    assert np.abs(mis - ref)[:N].max() < 1e-7


def test_multirate_steps_of_the_python_twin_agree_with_the_compiled_kernels():
    """The first 8 steps of the P3 collision (two of them multirate steps of 120 fast sub-steps,
    the impact among them) by kernels.PY and kernels.JIT: the same statements, the same state
    (measured: identical, bit for bit).
    """
    params = with_steel_balls(load_scenario('p3').params, rotation=True)
    n = params.n
    P = kernels.pack_params(params)
    y0, S = p3_state(params)
    out = []
    for kern in (kernels.JIT, kernels.PY):
        y = y0.copy()
        work = kernels.make_work(n)
        assert kern.advance(y, 0.0, 1e-4, 0, 8, P, S, work)[0] == 8
        out.append((y, work[W_STATS, STAT_REFINED]))
    assert out[0][1] == out[1][1] > 0                   # refined steps, multirate
    np.testing.assert_allclose(out[1][0], out[0][0], rtol=1e-12, atol=1e-15)


def head_on(speed, onset, dt=1e-4):
    """Return the clamped race and a head-on collision at ``speed`` starting at ``onset``.

    The clamped race's head-on collision at ``speed`` [m/s] whose contact begins at the fraction
    ``onset`` of the first step of dt (10 kHz: test_contact_rolling.clamped).
    """
    params = clamped_race(2, 0.78e-3)
    return params, collision_state(params, 0.0, gap=speed * dt * onset, speed=speed)


@pytest.mark.parametrize('speed', [0.01, 0.02, 0.05, 0.5])
def test_impacts_rebound_to_an_absolute_or_relative_tolerance_whichever_is_looser(speed):
    """A slow impact's sub-steps are longer (kernels.contact_steps.impact_relaxation) and its
    rebound speeds stay right to 1e-5 m/s (CONTACT_IMPACT_SPEED times the relative error 7.8e-5
    of a fast impact); a fast impact's (0.5 m/s) stay right to 7.8e-5 of the speed. The head-on
    collision on the clamped race, its contact starting at 16 instants within the first step,
    against the same run at steps of dt / 200 (omega_c h ~ 0.01). Measured, worst onset:
    3.2e-6, 3.3e-6, 3.5e-6 m/s, 3.6e-5 of 0.5 m/s (docs/ball_size_contact_rolling.md). The
    onsets late in the step put the impact's peak near the next step's start, where the contact
    looks resting (kernels.contact_steps.resting_misjudged takes that step again: without it
    7.8e-4 m/s at 0.05 m/s).
    """
    errors = []
    for k in range(16):
        params, y0 = head_on(speed, (k + 0.5) / 16)
        sim = Simulation(params, 0.0, spindle=ConstantSpeed(), y0=y0)
        sim.advance(20)
        ref = Simulation(params, 0.0, spindle=ConstantSpeed(), y0=y0, dt=1e-4 / 200)
        ref.advance(20 * 200)
        errors.append(np.abs(sim.phi_rates - ref.phi_rates).max() * params.R)
    print(f'{speed} m/s: rebound speeds right to {max(errors):.2e} m/s at worst')
    tolerance = max(kernels.CONTACT_IMPACT_SPEED, speed) * 7.8e-5
    assert max(errors) < tolerance


def test_slow_impacts_take_fewer_sub_steps_than_fast_ones_would_at_their_speed(monkeypatch):
    """The multirate step's sub-steps for the head-on collision at 0.01 m/s, just before the
    contact: with impact_relaxation (compiled) about half those of the relative rule (the Python
    twin with CONTACT_RELAX_MAX = 1, i.e. no relaxation); at 0.5 m/s the same.
    """
    counts = {}
    for speed in (0.01, 0.5):
        params, y0 = head_on(speed, 0.25)
        P = kernels.pack_params(params)
        counts[speed] = [K.mis_substeps(y0, 2, P, 1e-4)]
        with monkeypatch.context() as patch:
            patch.setattr(kernels.contact_steps, 'CONTACT_RELAX_MAX', 1.0)
            counts[speed].append(kernels.PY.mis_substeps(y0, 2, P, 1e-4))
    print(f'sub-steps (relaxed, relative rule): {counts}')
    assert counts[0.01][0] < 0.55 * counts[0.01][1]
    assert counts[0.5][0] == counts[0.5][1]


@pytest.mark.parametrize('speed', [1e-4, 2e-3, 0.05, 0.128, 1.0])
def test_impact_relaxation_follows_the_measured_error_law(speed):
    """(CONTACT_IMPACT_SPEED / v)^(1 / 2.7), between 1 and CONTACT_RELAX_MAX, v the impact speed of
    the peak overlap's 'energy' delta^2.5 = 5/8 m_b v^2 / K (kernels.contact_steps.contact_regime).
    """
    stiffness, mb = 4.25e9, 1.56e-4
    energy = 0.625 * mb * speed ** 2 / stiffness
    expected = min(max((kernels.CONTACT_IMPACT_SPEED / speed) ** (1 / 2.7), 1.0),
                   kernels.CONTACT_RELAX_MAX)
    for kern in (K, kernels.PY):
        assert kern.impact_relaxation(energy, stiffness, mb) == pytest.approx(expected,
                                                                              rel=1e-12)


def test_an_impact_caught_near_its_peak_is_not_taken_for_a_resting_contact():
    """The head-on collision at 0.05 m/s whose contact begins late in the first step: the next step
    starts near the impact's peak, where the overlap's energy exceeds the rate's, so contact_regime
    takes it for a resting contact (few sub-steps); resting_misjudged sees the rebound at the
    step's end and contact_step takes the step again with the contact resolved as an impact (the
    rebound then right to 3.4e-6 m/s: the test above).
    """
    params, y0 = head_on(0.05, 13.5 / 16)
    n, N = 2, 9
    P = kernels.pack_params(params)
    sim = Simulation(params, 0.0, spindle=ConstantSpeed(), y0=y0)
    sim.advance(1)
    start = sim.y.copy()
    sub, impact = K.contact_regime(start, n, P, 1e-4)
    assert not impact and kernels.PY.pair_state(start, n, P, 0, 1)[0] > 0   # touching
    rest = start.copy()
    bufs = solver_buffers(n)
    S = ConstantSpeed().pack(0.0)
    K.mis_contact_step(1e-4, 1e-4, rest, n, P, S, sub, np.empty((0, 2 * N)), bufs)
    assert K.resting_misjudged(start, rest, n, P, 1e-4)
    kept = start.copy()
    rows = K.contact_step(1e-4, 1e-4, kept, start, n, P, S, (sub, impact),
                          np.empty((0, 2 * N)), bufs)
    forced = K.contact_regime_as(start, n, P, 1e-4, True)[0]
    print(f'contact sub-steps as resting {sub}, as an impact {forced}; the step kept: {rows} '
          'fast sub-steps (merged where the balls are apart)')
    assert rows > sub and not np.array_equal(kept, rest)


@pytest.mark.parametrize('onset', [2.5 / 16, 13.5 / 16])
def test_in_torque_mode_an_impact_near_its_peak_is_taken_again_too(onset):
    """The same head-on collision (0.05 m/s) with the spindle in torque mode (no current, the rotor
    free; whole-system RK4 sub-steps instead of the multirate step): its rebound speeds against the
    same run at dt / 200, the contact starting early in the first step, and late (its peak near the
    next step's start: that step is taken again). In an impact these sub-steps are
    MIS_IMPACT_REFINE times as many, as the multirate step's (omega_c h 0.2), so to the same 1e-5
    m/s. Measured: 2.6e-6 and 1.3e-6 m/s; 6.2e-6 and 1.4e-5 m/s at omega_c h 0.3; 3.3e-6 and
    7.7e-4 m/s with the late one resolved as resting.
    """
    params, y0 = head_on(0.05, onset)
    runs = []
    for dt, steps in ((1e-4, 20), (1e-4 / 200, 4000)):
        sim = Simulation(params, 0.0, dt=dt, spindle=TorqueMotor(), y0=y0)
        sim.set_command(0.0)
        sim.advance(steps)
        runs.append(sim.phi_rates * params.R)
    error = np.abs(runs[0] - runs[1]).max()
    print(f'onset {onset:.3f} of the step: rebound speeds right to {error:.2e} m/s')
    assert error < kernels.CONTACT_IMPACT_SPEED * 7.8e-5


@functools.cache
def gathered_chain():
    """Return (params, t, state) of ten steel balls gathered into a chain.

    (params, t, state): ten steel balls gathered into a chain at P1 (the node's n = 10 drive, after
    1.2 s at 10 kHz).
    """
    params = with_steel_balls(DriveParams().replace(m=1.56e-4, D=1e-6, n=10, c=0.66))
    sim = Simulation(params, 0.8 * params.omega0)
    sim.advance(12000)
    return params, sim.t, sim.y.copy()


@pytest.mark.parametrize('dt', [1e-5, 3e-5, 1e-4, 2e-4])
def test_a_resting_chain_is_never_taken_again(dt):
    """The gathered chain, continued at steps of dt: over the next 1000 steps every step has
    contacts resolved as resting (in sub-steps, or in one RK4 step at 1e-5 s: omega_c dt ~ 0.5) and
    none is taken again: its first multirate step at mis_substeps, or its one RK4 step, leaves
    retake_substeps at 0 (as kernels.stepper.step decides).
    """
    params, t0, y0 = gathered_chain()
    sim = Simulation(params, 0.8 * params.omega0, dt=dt, y0=y0, t0=t0)
    n, N = params.n, 7 + params.n
    P = kernels.pack_params(params)
    S = sim.spindle.pack(sim.omega_cmd)
    bufs = solver_buffers(n)
    stages = kernels.stage_buffers(n)
    retaken = resting = 0
    for _ in range(1000):
        start = sim.y.copy()
        sub, impact, rests = K.contact_regimes(start, n, P, dt, False)
        first = start.copy()
        if sub == 1:
            K.rk4_substep(sim.t, dt, first, n, P, S, stages, bufs)
        else:
            sub = K.mis_substeps(start, n, P, dt)
            K.mis_contact_step(sim.t, dt, first, n, P, S, sub, np.empty((0, 2 * N)), bufs)
        retaken += K.retake_substeps(start, first, n, P, dt, impact, sub,
                                     kernels.MIS_IMPACT_REFINE) > 0
        resting += rests and not impact
        sim.advance(1)
        np.testing.assert_array_equal(first, sim.y)     # the step the simulation kept
    print(f'dt {dt:g} s: resting steps {resting}, refined {sim.refined_steps}, '
          f'retaken {retaken}')
    assert resting == 1000 and retaken == 0

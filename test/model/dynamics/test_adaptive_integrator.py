"""The adaptive Dormand-Prince 5(4) integrator (kernels/adaptive.py) against DOP853 and RK4."""

import math

import numpy as np
import pytest

from abb_ros.app.headless import run_scenario
from abb_ros.io.files.scenario import load_scenario
from abb_ros.model.dynamics import integrate as I
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.reference import reference_solution
from abb_ros.model.parameters.params import ParamError
from abb_ros.sweep.compute import compute_partition
from abb_ros.sweep.sampling import draw_samples
from abb_ros.sweep.spec import parse_spec

X0 = 0.3e-3
"""The initial deck displacement [m] the errors are relative to (Section 5)."""


def _run(name, seconds, integrator, every=10, **settings):
    sc = load_scenario(name)
    if settings:
        sc = sc.with_settings(settings)
    y0 = initial_state(sc.params, sc.omega, phi0=sc.phi0, deck0=sc.deck0)
    sim = I.Simulation(sc.params, sc.omega, spindle=sc.spindle, y0=y0, integrator=integrator)
    ys = sim.trajectory(int(round(seconds / sim.dt)), every)
    return sc, y0, sim, ys


@pytest.mark.parametrize('name', ['p3', 'p3_n10'])
def test_publish_samples_match_a_tight_dop853_reference_over_the_whole_run(name):
    """At every 1 kHz stamp of 2 s of P3 the dense output is within RK4's own error.

    Deck translations within 5e-7 of the 0.3 mm start (measured 1.4e-7; RK4 at 10 kHz has
    6.7e-7), ball angles within 1e-5 deg (measured 2e-6), against DOP853 at rtol 1e-11; the
    steps (about 3 ms once settled) are longer than the 1 ms between samples, so the samples
    come from the continuous extension, not from step ends.
    """
    sc, y0, sim, ys = _run(name, 2.0, 'adaptive')
    t = np.arange(1, len(ys) + 1) * 1e-3
    ref = reference_solution(sc.params, y0, (0.0, 2.0), spindle=sc.spindle, rtol=1e-11,
                               atol=1e-14, t_eval=t).y.T
    N = sim.N
    assert np.abs(ys[:, 1:4] - ref[:, 1:4]).max() / X0 < 5e-7
    assert np.degrees(np.abs(ys[:, 7:N] - ref[:, 7:N])).max() < 1e-5
    assert sim.adaptive_counts['step'] > 1e-3


@pytest.mark.parametrize('name', ['p3', 'p3_n10'])
def test_settled_ball_angles_agree_with_rk4_within_0_01_deg(name):
    """After 10 s of P3 the two integrators leave the balls within 0.01 deg (measured 1e-4).

    And the adaptive one calls the right-hand side under a quarter as often (measured 34,000
    calls against RK4's 400,000).
    """
    _, _, rk4, yr = _run(name, 10.0, 'rk4', every=1000)
    _, _, ad, ya = _run(name, 10.0, 'adaptive', every=1000)
    N = ad.N
    assert ad.integrator_used == 'adaptive' and rk4.integrator_used == 'rk4'
    assert np.degrees(np.abs(ya[-1, 7:N] - yr[-1, 7:N])).max() < 0.01
    assert ad.adaptive_counts['nfev'] < 4 * 10.0 / rk4.dt / 4


def test_speed_commands_restart_the_integrator_at_their_stamps():
    """Through a spin-up's command and resonance the adaptive run beats RK4 at 10 kHz.

    The command changes the spindle's law, so the integrator restarts at its stamp rather than
    step across it. Against RK4 at half the step (its error 16x smaller) the adaptive samples
    are within a third of RK4's own distance (measured 4.8e-8 m against 3.4e-7 m, peak
    2.5 mm), the same stamps, the settled balls within 0.01 deg.
    """
    sc = load_scenario('spinup_p1_p3')
    a = run_scenario(sc, integrator='adaptive')
    r = run_scenario(sc)
    fine = run_scenario(sc, dt=I.DEFAULT_DT / 2)
    assert a.integrator == 'adaptive' and a.integrator_note == ''
    assert np.array_equal(a.t, r.t)
    deck = slice(1, 4)
    assert (np.abs(a.y[:, deck] - fine.y[:, deck]).max()
            < np.abs(r.y[:, deck] - fine.y[:, deck]).max() / 3)
    phi = slice(7, 7 + sc.params.n)
    assert np.degrees(np.abs(a.y[-1, phi] - r.y[-1, phi])).max() < 0.01


@pytest.mark.parametrize('setting', [{'contact_E': 2.0e11, 'r_ball': 2.0e-3},
                                     {'rolling_mu': 2.0e-6, 'r_ball': 2.0e-3}])
def test_contact_and_rolling_resistance_fall_back_to_the_fixed_step_bit_for_bit(setting):
    """Take the fixed RK4 step for a drive whose laws switch inside a step, and say so."""
    _, _, ad, ya = _run('p3', 0.05, 'adaptive', **setting)
    _, _, rk4, yr = _run('p3', 0.05, 'rk4', **setting)
    assert ad.integrator_used == 'rk4'
    assert np.array_equal(ya, yr)
    name = next(iter(setting))   # contact_E or rolling_mu
    sc = load_scenario('p3').with_settings(setting)
    sc.duration = 0.01
    note = run_scenario(sc, integrator='adaptive').integrator_note
    assert 'fixed RK4 step' in note and name in note


def test_an_unknown_integrator_is_refused_naming_the_parameter():
    """Refuse a name other than rk4 or adaptive, in the model and in a sweep spec."""
    sc = load_scenario('p3')
    with pytest.raises(ParamError, match='integrator.*rk4 or adaptive'):
        I.Simulation(sc.params, sc.omega, integrator='euler')
    with pytest.raises(ParamError, match='compute.run.integrator'):
        parse_spec({'parameters': {'k': {'dist': 'grid', 'values': [3972.0]}},
                    'compute': {'run': {'duration': 0.02, 'integrator': 'dopri'}}})


def test_sweep_runs_by_the_adaptive_integrator_give_rk4s_metrics():
    """Give the same final rbar, ball angles and settle time as the fixed-step batch kernel.

    Settle times within 2 ms (the time the samples cross the limit, read at every step of
    dt from the dense output), ball angles within 0.01 deg, final rbar within 1e-6.
    """
    doc = {'parameters': {'eps': {'dist': 'uniform', 'low': 0.1e-3, 'high': 0.5e-3}},
           'samples': 3, 'sampling': {'method': 'lhs', 'seed': 2},
           'compute': {'run': {'duration': 1.0, 'rbar_limit': 1e-3}}}
    res = {}
    for name in I.INTEGRATORS:
        doc['compute']['run']['integrator'] = name
        spec = parse_spec(doc)
        res[name] = compute_partition(spec, 0, draw_samples(spec))
    a, r = res['adaptive'], res['rk4']
    assert not a['failed'].any()
    np.testing.assert_allclose(a['final_rbar'], r['final_rbar'], atol=1e-6)
    np.testing.assert_allclose(a['peak_rbar'], r['peak_rbar'], rtol=1e-4)
    np.testing.assert_allclose(a['settle_time'], r['settle_time'], atol=2e-3)
    for pa, pr in zip(a['phi_final_deg'], r['phi_final_deg']):
        assert np.abs(np.asarray(pa) - np.asarray(pr)).max() < 0.01
    assert math.isfinite(float(a['settle_time'][0]))


def test_an_adaptive_bag_carries_every_topic_at_the_fixed_step_runs_stamps(abb_sim, tmp_path):
    """Write the same topics, message counts and stamps as the rk4 bag; refuse a bad name.

    The IMU and the FG are read from the dense-output states, so their readings agree with
    the rk4 bag's to the integrators' difference (accelerations within 1e-3 m/s^2).
    """
    import json

    from abb_ros.io.bag.reader import read_bag
    bags = {}
    for name in I.INTEGRATORS:
        out = tmp_path / name
        code, stdout, err = abb_sim('run', '--scenario', 'p3', '--duration', '0.2', '--out',
                                    str(out), '--json', '--no-progress', '--integrator', name)
        assert code == 0, err
        assert json.loads(stdout)['integrator'] == name
        bags[name] = [(topic, stamp, msg) for topic, msg, stamp in read_bag(out)]
    a, r = bags['adaptive'], bags['rk4']
    assert [(t, s) for t, s, _ in a] == [(t, s) for t, s, _ in r]
    imu = [(ma, mr) for (t, _, ma), (_, _, mr) in zip(a, r) if t.endswith('imu')]
    assert imu and max(abs(ma.linear_acceleration.x - mr.linear_acceleration.x)
                       for ma, mr in imu) < 1e-3
    code, _, err = abb_sim('run', '--integrator', 'euler')
    assert code == 2 and '--integrator' in err


def test_the_dormand_prince_tableau_is_scipys_rk45_one():
    """c, a and b equal scipy's RK45 tableau to the last bit; its error weights are the
    fourth- minus fifth-order ones, ours the fifth- minus fourth-order (the opposite sign)."""
    from scipy.integrate import RK45

    from abb_ros.model.dynamics.kernels import adaptive
    assert np.array_equal(adaptive.DP_C, RK45.C)
    assert np.array_equal(adaptive.DP_A, RK45.A)
    assert np.array_equal(adaptive.DP_B, RK45.B)
    assert np.array_equal(adaptive.DP_E, -RK45.E)
    assert adaptive.A54 == RK45.A[4, 3] and adaptive.E7 == -RK45.E[6]

"""`abb-sim basin`: rows that are abb-sim run's, the fraction and its interval, bad input.

Serial (in-process) studies only; the cluster and resuming are in test_basin_cluster.py.
"""

import json
import math

import numpy as np
import pytest
from scipy.stats import binomtest

from abb_ros.app.headless import run_scenario
from abb_ros.basin.study import read_table
from abb_ros.basin.summary import floquet_verdict, fraction_summary
from abb_ros.cli import main
from abb_ros.io.files.scenario import load_scenario
from abb_ros.model.dynamics.state import StateLayout, wrap_degrees
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.stability import two_plane
from abb_ros.model.stability.outcomes import EQ26_NEAR, classify, packed
from abb_ros.sweep.proportions import wilson


def _basin(tmp_path, capsys, *extra, name='out'):
    out = tmp_path / name
    code = main(['basin', '--out', str(out), '--serial', '--no-progress', '--json', *extra])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return out, json.loads(captured.out)


@pytest.fixture(scope='module')
def small_study(tmp_path_factory):
    """A 3 x 4 grid of 0.3 s runs at P3 (12 starts), computed once for several claims."""
    import contextlib
    import io
    out = tmp_path_factory.mktemp('basin') / 'out'
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(['basin', '--res', '3x4', '--duration', '0.3', '--out', str(out),
                     '--serial', '--no-progress', '--json', '--partition-size', '5'])
    assert code == 0
    return out, json.loads(buf.getvalue())


def _bits(x):
    return np.asarray(x, dtype=float).view(np.uint64)


@pytest.mark.slow
def test_basin_rows_reproduce_abb_sim_run_from_the_same_start_bit_for_bit(
        small_study, tmp_path, capsys):
    """Each row's final rbar, ball angles and speed are those of abb-sim run from its start."""
    out, _ = small_study
    table = read_table(out).to_pydict()
    for row in (0, 7, 11):
        start = [table['phi1_deg'][row], table['phi2_deg'][row]]
        text = load_scenario('p3')
        path = tmp_path / f'start{row}.yaml'
        path.write_text('name: p3\nset: {mbar: 0.03, c: 0.66, wbar: 2.7}\n'
                        'initial:\n  deck: [0.3e-3, 0.3e-3, 0.3e-3, 0.0, 0.0, 0.0]\n'
                        f'  phi_deg: [{start[0]!r}, {start[1]!r}]\nduration: 0.3\n')
        assert main(['run', '--scenario', str(path), '--no-progress', '--json']) == 0
        summary = json.loads(capsys.readouterr().out)
        assert _bits(summary['final_rbar']) == _bits(table['final_rbar'][row])
        scen = load_scenario(str(path))
        y = run_scenario(scen).y[-1]
        layout = StateLayout.of(2)
        assert np.array_equal(_bits(wrap_degrees(layout.phi(y))),
                              _bits([table['phi1_final_deg'][row], table['phi2_final_deg'][row]]))
        assert _bits(layout.omega(y)) == _bits(table['omega_final'][row])
        assert text.params == scen.params


@pytest.mark.slow
def test_adaptive_basin_rows_are_abb_sim_runs_with_the_adaptive_integrator(tmp_path, capsys):
    """--integrator adaptive: each row is abb-sim run --integrator adaptive from its start."""
    out, summary = _basin(tmp_path, capsys, '--res', '2x2', '--duration', '0.3',
                          '--integrator', 'adaptive')
    assert summary['integrator'] == 'adaptive'
    table = read_table(out).to_pydict()
    for row in range(4):
        start = [table['phi1_deg'][row], table['phi2_deg'][row]]
        path = tmp_path / f'start{row}.yaml'
        path.write_text('name: p3\nset: {mbar: 0.03, c: 0.66, wbar: 2.7}\n'
                        'initial:\n  deck: [0.3e-3, 0.3e-3, 0.3e-3, 0.0, 0.0, 0.0]\n'
                        f'  phi_deg: [{start[0]!r}, {start[1]!r}]\nduration: 0.3\n')
        assert main(['run', '--scenario', str(path), '--no-progress', '--json',
                     '--integrator', 'adaptive']) == 0
        run = json.loads(capsys.readouterr().out)
        assert run['integrator'] == 'adaptive'
        assert _bits(run['final_rbar']) == _bits(table['final_rbar'][row])


def test_fraction_and_interval_are_those_of_the_rows(small_study):
    """balanced_fraction is balanced rows / runs, ci95 the Wilson interval of that count."""
    out, summary = small_study
    table = read_table(out).to_pydict()
    k = sum(table['balanced'])
    assert summary['runs'] == len(table['balanced']) == 12
    assert summary['balanced'] == k
    assert summary['balanced_fraction'] == k / 12
    assert summary['ci95'] == list(wilson(k, 12))
    assert sum(summary['outcomes'].values()) == 12
    assert all(b == (o == 'balanced') for b, o in zip(table['balanced'], table['outcome']))
    assert summary['integrator'] == 'rk4'
    assert summary['floquet_balanced'] is True     # P3 is balanced (Fig. 7b)
    assert json.loads((out / 'basin.json').read_text())['ci95'] == summary['ci95']
    assert (out / 'basin.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


@pytest.mark.parametrize('k,n', [(0, 1), (0, 12), (3, 12), (12, 12), (517, 1024), (1, 10000)])
def test_wilson_interval_matches_scipy_binomtest(k, n):
    """The Wilson score interval equals scipy.stats.binomtest(k, n).proportion_ci('wilson').

    Both evaluate the same closed form; 1e-12 allows for the order of the operations.
    """
    ci = binomtest(k, n).proportion_ci(0.95, method='wilson')
    lo, hi = wilson(k, n)
    assert lo == pytest.approx(ci.low, abs=1e-12)
    assert hi == pytest.approx(ci.high, abs=1e-12)


def test_overlapping_starts_are_left_out_of_the_fraction():
    """An 'overlap' start (balls with contact started inside each other) is not a run."""
    s = fraction_summary(['balanced', 'overlap', 'moving', 'balanced'])
    assert s['runs'] == 3 and s['balanced'] == 2
    assert s['balanced_fraction'] == 2 / 3
    assert s['outcomes']['overlap'] == 1


def _rest_run(params, phi_end_deg, rbar, drift_deg=0.0):
    """Synthetic samples: balls at phi_end (drifting by drift_deg over the run), deck at rbar."""
    t = np.linspace(0.0, 1.0, 1001)
    layout = StateLayout.of(params.n_balls)
    ys = np.zeros((t.size, 2 * (7 + params.n_balls)))
    phi = np.radians(phi_end_deg)[None, :] + np.radians(drift_deg) * (t[:, None] - 1.0)
    ys[:, layout.phi_slice] = phi
    ys[:, 1] = rbar * params.R
    return t, ys


def test_classes_of_synthetic_ends():
    """Each class is given by its definition (docs/basin.md), at P3's drive."""
    p = load_scenario('p3').params
    star = math.degrees(math.acos(-p.M * p.eps / (2 * p.m * p.R)))
    cases = {'balanced': _rest_run(p, np.array([-star, star]), 1e-4),
             'settling': _rest_run(p, np.array([-star, star]), 5e-3),
             'packed': _rest_run(p, np.array([-10.0, -9.5]), 2e-2),
             'unbalanced_rest': _rest_run(p, np.array([-60.0, 60.0]), 2e-2),
             'moving': _rest_run(p, np.array([-star, star]), 1e-4, drift_deg=30.0),
             # two laps of the rotor within the rest window (the last 0.1 s)
             'drifting': _rest_run(p, np.array([-star, star]), 1e-4, drift_deg=7200.0)}
    for name, (t, ys) in cases.items():
        assert classify(p, t, ys, 1e-3)[0] == name
    rolling = p.replace(rolling_mu=1e-3, r_ball=1e-3)
    t, ys = _rest_run(rolling, np.array([-60.0, 60.0]), 2e-2)
    assert classify(rolling, t, ys, 1e-3)[0] == 'friction_rest'


def test_two_races_are_balanced_only_where_they_cancel_the_couple_too():
    """G 1 mm above race 1 and race 2 at 2 mm: the closed form's angles are balanced; race 1
    alone cancelling the force (race 2's pair opposite, no resultant) leaves the couple."""
    p = load_scenario('p3').params.replace(**{'z_G': 1e-3, 'race2.n': 2, 'race2.z': 2e-3})
    closed = np.degrees(np.concatenate(two_plane.drive_balance(p).phi))
    star = math.degrees(math.acos(-p.M * p.eps / (2 * p.m * p.R)))
    force_only = np.array([-star, star, -90.0, 90.0])
    assert classify(p, *_rest_run(p, closed, 1e-4), 1e-3)[0] == 'balanced'
    outcome, residual, _ = classify(p, *_rest_run(p, force_only, 1e-4), 1e-3)
    assert outcome == 'unbalanced_rest' and residual > EQ26_NEAR


@pytest.mark.parametrize('n, n2, removed, balanced', [(3, 3, 2, True), (2, 2, 0, True),
                                                      (3, 1, 0, False)])
def test_the_verdict_is_transverse_only_where_a_family_of_balanced_states_was_removed(
        n, n2, removed, balanced):
    """Two races: 3 + 3 balls leave a 2-parameter family beyond both planes' four conditions;
    2 + 2 balance at one point; 3 + 1 cannot (race 2's one ball is a fixed m R, not the
    correction its plane needs): no balanced state, nothing removed."""
    scenario = load_scenario('p3')
    p = scenario.params.replace(**{'n': n, 'z_G': 1e-3, 'race2.n': n2, 'race2.z': 2e-3})
    verdict = floquet_verdict(p, scenario.omega)
    assert verdict['neutral_modes_removed'] == removed
    assert verdict['transverse'] is (removed > 0)
    assert verdict['balanced'] is balanced


def test_packed_means_one_chain_of_touching_balls():
    """Balls side by side within the separation plus 1 deg are packed; a gap apart is not."""
    s = math.radians(8.0)
    assert packed(np.radians([10.0, 18.5, 27.0]), s)
    assert not packed(np.radians([10.0, 18.5, 40.0]), s)
    assert packed(np.radians([179.5, -179.9]), 0.0)
    assert not packed(np.radians([0.0]), 0.0)


def test_samples_are_drawn_uniformly_from_the_stated_seed(tmp_path, capsys):
    """--samples K: the starts are default_rng(seed).uniform(-180, 180, (K, n))."""
    out, summary = _basin(tmp_path, capsys, '--scenario', 'p3', '--set', 'n=3',
                          '--samples', '3', '--seed', '7', '--duration', '0.05')
    table = read_table(out).to_pydict()
    expected = np.random.default_rng(7).uniform(-180, 180, (3, 3))
    got = np.array([table[f'phi{i}_deg'] for i in (1, 2, 3)]).T
    assert np.array_equal(got, expected)
    assert summary['floquet']['transverse'] is True
    assert summary['floquet']['neutral_modes_removed'] == 1
    assert 'default_rng(7)' in summary['sampler']


@pytest.mark.parametrize('argv,needle', [
    (['--res', '200x200'], '--res'),
    (['--res', '8'], '--res'),
    (['--samples', '0'], '--samples'),
    (['--res', '4x4', '--scenario', 'no_such_scenario'], 'scenario'),
    (['--res', '4x4', '--set', 'n=3'], 'n = 2'),
    (['--res', '4x4', '--workers', '0'], '--workers'),
    (['--res', '4x4', '--rbar-limit', '-1'], '--rbar-limit'),
    (['--res', '4x4', '--duration', '-1'], 'duration'),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, argv, needle):
    """Bad input names the option and what is valid, in one line, exit 2, nothing written."""
    out = tmp_path / 'out'
    assert main(['basin', '--out', str(out), '--no-progress', *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err, err
    assert not out.exists()


def test_an_existing_directory_needs_resume(small_study, capsys):
    """A study into a non-empty directory without --resume is refused (exit 2)."""
    out, _ = small_study
    assert main(['basin', '--res', '3x4', '--out', str(out), '--serial', '--no-progress']) == 2
    assert '--resume' in capsys.readouterr().err


def test_no_balls_is_refused(tmp_path, capsys):
    """A drive with fewer than two balls has no basin to study (exit 2)."""
    assert main(['basin', '--samples', '4', '--set', 'n=1', '--out', str(tmp_path / 'o'),
                 '--serial']) == 2
    assert 'at least 2 balls' in capsys.readouterr().err
    assert DriveParams().n == 2


def test_balls_with_contact_are_not_started_inside_each_other(tmp_path, capsys):
    """With contact the grid's diagonal starts overlap: class 'overlap', not run, not counted."""
    out, summary = _basin(tmp_path, capsys, '--res', '2x2', '--duration', '0.05',
                          '--set', 'r_ball=2.3559716663050265e-3', '--set', 'contact_E=2e11')
    table = read_table(out).to_pydict()
    diagonal = [a == b for a, b in zip(table['phi1_deg'], table['phi2_deg'])]
    assert [o == 'overlap' for o in table['outcome']] == diagonal == [True, False, False, True]
    assert summary['runs'] == 2 and summary['outcomes']['overlap'] == 2
    assert all(math.isnan(r) for r, d in zip(table['final_rbar'], diagonal) if d)

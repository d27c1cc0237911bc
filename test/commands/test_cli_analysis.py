"""`abb-sim stability`, `abb-sim freqs` and `abb-sim map`, in-process through ``cli.main``
(the console script: test_cli_smoke.py)."""

import json

import numpy as np
import pytest

from abb_ros.cli import main


def _json(capsys, argv):
    code = main(argv + ['--json'])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if code == 0 else None), out.err


def test_stability_at_p3_reports_balanced_with_balls_on_the_far_side(capsys):
    code, s, _ = _json(capsys, ['stability', '--set', 'zeta=0.025', '--set', 'mbar=0.03',
                                '--set', 'wbar=2.7'])
    assert code == 0 and s['verdict'] == 'balanced' and s['balanced'] is True
    assert s['phi_star_deg'] == pytest.approx([-106.128, 106.128], abs=1e-3)
    assert s['lam_max_in_plane'] < 1 and s['lam_max_out_of_plane'] < 1


def test_stability_at_p4_says_unbalanced_and_why_without_nan(capsys):
    code = main(['stability', '--set', 'epsbar=0.04', '--set', 'wbar=2.7', '--json'])
    text = capsys.readouterr().out
    s = json.loads(text)
    assert code == 0 and 'NaN' not in text and 'Infinity' not in text
    assert s['verdict'].startswith('unbalanced') and 'capacity' in s['reason']


def test_stability_explicit_phi_star_is_checked_against_eq26(capsys):
    code, _, err = _json(capsys, ['stability', '--set', 'wbar=2', '--phi-star=10,20'])
    assert code == 2 and 'phi_star' in err and 'Eq. (26)' in err
    code, s, _ = _json(capsys, ['stability', '--set', 'wbar=2',
                                '--phi-star=120.25676507190296,-120.25676507190296'])
    assert code == 0 and s['balanced_equilibrium_exists']


@pytest.mark.parametrize('argv, needle', [
    (['stability'], 'wbar'),
    (['stability', '--set', 'wbar=2', '--set', 'zeta=-1'], 'zeta'),
    (['map', '--x', 'wbar', '--y', 'mbar', '--res', '3', '--out', 'x.png'], '--res'),
    (['map', '--x', 'wbar', '--y', 'mbar', '--range-x', '2:1', '--out', 'x.png'], 'range-wbar'),
    (['map', '--x', 'zeta', '--y', 'Dbar', '--res', '3x3', '--out', 'x.png'], 'wbar'),
])
def test_bad_input_exits_2_naming_the_problem(capsys, argv, needle):
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2 and needle in err


def test_freqs_lists_the_natural_frequencies_in_rad_per_s(capsys):
    code, s, _ = _json(capsys, ['freqs'])
    assert code == 0
    for name, paper in s['paper_rad_s'].items():
        assert s[f'omega_{name}_rad_s'] == pytest.approx(paper, rel=0.04)  # as test_linear


def test_map_writes_png_and_data_with_fixed_parameters(capsys, tmp_path):
    png = tmp_path / 'fig7b.png'
    code, s, err = _json(capsys, ['map', '--x', 'wbar', '--y', 'mbar', '--set', 'zeta=0.025',
                                  '--res', '16x10', '--range-y', '0.001:0.1', '--out', str(png),
                                  '--no-progress'])
    assert code == 0 and png.stat().st_size > 10_000
    d = np.load(s['data'])
    assert d['lam_max'].shape == (10, 16) and d['status'].shape == (10, 16)
    assert json.loads(str(d['fixed_json']))['settings'] == {'zeta': 0.025}
    assert json.loads(str(d['limits_json']))['mbar_lim'] == pytest.approx(1 / 120)
    # below mbar_lim: no balanced equilibrium (status 2, lam_max +inf), never NaN
    assert np.all(d['status'][0] == 2) and not np.isnan(d['lam_max']).any()
    assert 0 < s['balanced_fraction'] < 1


def test_map_csv_and_out_of_plane(capsys, tmp_path):
    csv = tmp_path / 'fig8.csv'
    code, s, _ = _json(capsys, ['map', '--x', 'wbar', '--y', 'mbar', '--plane', 'out',
                                '--set', 'zeta=0.025', '--res', '6x4', '--data', str(csv),
                                '--out', str(tmp_path / 'fig8.png'), '--no-progress'])
    assert code == 0 and s['plane'] == 'out'
    rows = np.loadtxt(csv, delimiter=',')
    assert rows.shape == (24, 4)
    assert 'fixed' in csv.read_text().splitlines()[0]


def test_map_offers_exactly_the_axes_the_stability_map_varies():
    from abb_ros.commands.map import DEFAULT_RANGES
    from abb_ros.model.stability.floquet import MAP_AXES
    assert tuple(DEFAULT_RANGES) == MAP_AXES

"""Sweep specs: validation (one line naming the field, exit code 2), safe YAML, seeded draws."""

import textwrap

import numpy as np
import pytest

from abb_ros.cli import main
from abb_ros.model.parameters.params import ParamError
from abb_ros.sweep.sampling import draw_samples
from abb_ros.sweep.spec import MAX_SAMPLES, load_spec, parse_spec

GOOD = """\
name: t
scenario: p3
parameters:
  eps: {dist: normal, mean: 0.25e-3, std: 0.05e-3, low: 0.1e-3, high: 0.4e-3}
  k: {dist: uniform, low: 3600, high: 4400}
  n: {dist: list, values: [2, 3]}
  D: {dist: grid, low: 2.0e-6, high: 8.0e-6, points: 3}
samples: 20
sampling: {method: sobol, seed: 3}
partition_size: 7
compute:
  stability: {wbar: [2.2, 2.7]}
  run: {duration: 0.1, rbar_limit: 1.0e-3}
"""


def _write(tmp_path, text, name='spec.yaml'):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_good_spec_is_normalised_with_grid_times_samples_drives(tmp_path):
    spec = load_spec(_write(tmp_path, GOOD))
    assert spec.total == 60 and spec.partitions == 9
    assert spec.parameters['D']['values'] == pytest.approx([2e-6, 5e-6, 8e-6])
    # the operating speed (P3's wbar 2.7 of the nominal drive) is one of the speeds
    assert spec.operating_omega == pytest.approx(2.7 * spec.scenario.params.omega0)
    assert spec.operating_omega in spec.speeds and spec.speeds.size == 2


@pytest.mark.parametrize('method', ['random', 'lhs', 'sobol'])
def test_draws_are_reproducible_from_the_seed_and_inside_the_bounds(tmp_path, method):
    spec = load_spec(_write(tmp_path, GOOD.replace('sobol', method)))
    a, b = draw_samples(spec), draw_samples(spec)
    for name in a:
        assert np.array_equal(a[name], b[name])
    assert np.all((a['eps'] >= 0.1e-3) & (a['eps'] <= 0.4e-3))
    assert np.all((a['k'] >= 3600) & (a['k'] <= 4400))
    assert set(a['n']) == {2, 3} and a['n'].dtype == np.int64
    # grid outermost: every D value carries the same 20 draws
    assert np.array_equal(a['k'][:20], a['k'][20:40])
    assert np.array_equal(np.unique(a['D']), spec.parameters['D']['values'])
    other = load_spec(_write(tmp_path, GOOD.replace('seed: 3', 'seed: 4').replace('sobol', method),
                             'other.yaml'))
    assert not np.array_equal(draw_samples(other)['k'], a['k'])


def test_latin_hypercube_puts_one_draw_in_each_stratum(tmp_path):
    spec = load_spec(_write(tmp_path, GOOD.replace('sobol', 'lhs')))
    k = draw_samples(spec)['k'][:20]
    strata = np.floor((k - 3600) / 800 * 20).astype(int)
    assert sorted(strata) == list(range(20))


BAD = [
    ('unknown parameter', 'kk: {dist: uniform, low: 1, high: 2}', 'parameters.kk'),
    ('empty range', 'k: {dist: uniform, low: 4000, high: 4000}', 'parameters.k.high'),
    ('outside the valid range', 'c: {dist: normal, mean: 0.5, std: 0.1, low: -0.1, high: 1}',
     'parameters.c.low'),
    ('list value outside the range', 'm: {dist: list, values: [0.4e-3, 0.0]}',
     'parameters.m.values'),
    ('unknown distribution', 'k: {dist: gamma, low: 1, high: 2}', 'parameters.k.dist'),
    ('unknown key in a distribution', 'k: {dist: uniform, low: 1, high: 2, mean: 1.5}',
     'parameters.k.mean'),
    ('n drawn continuously', 'n: {dist: uniform, low: 1, high: 4}', 'parameters.n.dist'),
    ('a string for a number', 'k: {dist: uniform, low: soft, high: 2}', 'parameters.k.low'),
    ('no std', 'k: {dist: normal, mean: 4000, low: 3000, high: 5000}', 'parameters.k.std'),
]


@pytest.mark.parametrize('what, line, field', BAD, ids=[b[0] for b in BAD])
def test_bad_parameter_exits_2_with_one_line_naming_the_field(tmp_path, capsys, what, line,
                                                              field):
    text = f'parameters:\n  {line}\nsamples: 4\ncompute:\n  stability: {{wbar: [2.7]}}\n'
    code = main(['sweep', str(_write(tmp_path, text)), '--out', str(tmp_path / 'o'), '--serial'])
    err = capsys.readouterr().err
    assert code == 2, what
    assert err.count('\n') == 1 and field in err and 'valid' in err, err
    assert not (tmp_path / 'o').exists()


BAD_TOP = [
    ('samples over the limit', GOOD.replace('samples: 20', f'samples: {MAX_SAMPLES + 1}'),
     'samples'),
    ('drives over the limit with the grid', GOOD.replace('samples: 20', 'samples: 400000'),
     'samples'),
    ('samples of the wrong type', GOOD.replace('samples: 20', 'samples: twenty'), 'samples'),
    ('unknown top-level key', GOOD + 'sampels: 3\n', 'sampels'),
    ('unknown nested key', GOOD.replace('rbar_limit', 'rbar_limmit'),
     'compute.run.rbar_limmit'),
    ('unknown sampling key', GOOD.replace('method: sobol', 'mthod: sobol'), 'sampling.mthod'),
    ('unknown sampling method', GOOD.replace('sobol', 'halton'), 'sampling.method'),
    ('unknown compute', GOOD.replace('  run:', '  runs:'), 'compute.runs'),
    ('negative duration', GOOD.replace('duration: 0.1', 'duration: -1'),
     'compute.run.duration'),
    ('empty speed range', GOOD.replace('{wbar: [2.2, 2.7]}',
                                       '{range: {wbar: [3, 2], points: 5}}'),
     'compute.stability.range.wbar'),
    ('unknown scenario', GOOD.replace('scenario: p3', 'scenario: p9'), 'scenario'),
    ('base speed', GOOD + 'base: {wbar: 2}\n', 'base.wbar'),
    ('malformed YAML', GOOD + 'compute: [\n', 'spec'),
    ('not a mapping', '- 1\n- 2\n', 'a mapping'),
    ('alias', GOOD.replace('k: {dist: uniform, low: 3600, high: 4400}',
                           'k: &u {dist: uniform, low: 3600, high: 4400}\n  c: *u'), 'alias'),
]


@pytest.mark.parametrize('what, text, field', BAD_TOP, ids=[b[0] for b in BAD_TOP])
def test_bad_spec_exits_2_with_one_line_naming_the_field(tmp_path, capsys, what, text, field):
    code = main(['sweep', str(_write(tmp_path, text)), '--out', str(tmp_path / 'o'), '--serial'])
    err = capsys.readouterr().err
    assert code == 2, what
    assert err.count('\n') == 1 and field in err, err


def test_alias_bomb_and_huge_files_are_refused_before_parsing(tmp_path):
    bomb = 'a: &a ["x","x","x","x","x","x","x","x","x"]\n' + ''.join(
        f'{c}: &{c} [*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p}]\n'
        for p, c in zip('abcdefgh', 'bcdefghi'))
    with pytest.raises(ParamError, match='alias'):
        load_spec(_write(tmp_path, bomb, 'bomb.yaml'))
    with pytest.raises(ParamError, match='at most 1048576 bytes'):
        load_spec(_write(tmp_path, '#' * (1 << 20) + '\n' + GOOD, 'huge.yaml'))


def test_speeds_in_wbar_are_the_same_physical_speed_for_every_drive():
    doc = {'parameters': {'k': {'dist': 'list', 'values': [3000.0, 5000.0]}}, 'samples': 2,
           'base': {'k': 4000.0}, 'compute': {'stability': {'wbar': [2.0]}},
           'operating_wbar': 2.0}
    spec = parse_spec(doc)
    omega0 = spec.scenario.params.omega0
    assert spec.scenario.params.k == 4000.0
    assert spec.speeds == pytest.approx([2.0 * omega0])


def test_spec_file_names_a_scenario_file_relative_to_itself(tmp_path):
    (tmp_path / 'my.yaml').write_text(textwrap.dedent("""\
        name: mine
        set: {mbar: 0.03, c: 0.66, wbar: 2.5}
        duration: 2.0
        """))
    spec = load_spec(_write(tmp_path, GOOD.replace('scenario: p3', 'scenario: my.yaml')))
    assert spec.run['duration'] == 0.1 and spec.scenario.name == 'mine'
    assert spec.operating_omega == pytest.approx(2.5 * spec.scenario.params.omega0)

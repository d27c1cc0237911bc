"""Hostile command lines, class by class: exit code 2 (1 for a runtime failure), one line naming
the flag, field or parameter and what is valid, nothing on stderr beside it, within a bound time,
and nothing left behind that looks like a success.

The classes: extreme but finite numbers, work that grows with the input (checked before the
work), sweep specs, sweep directories that no sweep wrote, outputs that exist, and map flags
that name an axis the map sweeps. Run in-process through ``cli.main(argv)``.
"""

import time

import pytest

from abb_ros.cli import main


@pytest.fixture(scope='module', autouse=True)
def imported():
    """Import every command module once, so that time limits measure the command alone."""
    from abb_ros import cli
    for name in cli.SUBCOMMANDS:
        cli._load(name)
    import abb_ros.app.headless  # noqa: F401
    import abb_ros.model.stability.floquet  # noqa: F401


def refused(capsys, argv, code=2, seconds=5.0):
    """Run ``argv``; return its single stderr line after checking the contract."""
    t0 = time.perf_counter()
    got = main(argv)
    elapsed = time.perf_counter() - t0
    out = capsys.readouterr()
    lines = out.err.strip().splitlines()
    assert got == code, out.err
    assert len(lines) == 1, out.err
    assert 'Traceback' not in out.err and 'Warning' not in out.err
    assert elapsed < seconds, f'{elapsed:.1f} s'
    return lines[0]


# ---- extreme but finite numbers, and work that follows from the input ----------------------

MAP = ['map', '--x', 'wbar', '--y', 'mbar', '--res', '2x2', '--no-progress', '--out', 'm.png']

EXTREME_CASES = {
    'a stiffness of 1e300': (['stability', '--set', 'wbar=2', '--set', 'k=1e300'],
                             "'k' = 1e+300", '3.972e+09] N/m'),
    'a ball mass of 1e-300': (['stability', '--set', 'wbar=2', '--set', 'm=1e-300'], "'m'"),
    'a race radius of 1e10': (['stability', '--set', 'wbar=2', '--set', 'R=1e10'], "'R'"),
    'a damping of 1e300': (['stability', '--set', 'wbar=2', '--set', 'c=1e300'], "'c'"),
    'a drag of 1e300': (['stability', '--set', 'wbar=2', '--set', 'D=1e300'], "'D'"),
    'zeta of 1e300': (['stability', '--set', 'wbar=2', '--set', 'zeta=1e300'], "'zeta'",
                      'c in [0, 2.53e+06] kg/s'),
    'Dbar of 1e300': (['stability', '--set', 'wbar=2', '--set', 'Dbar=1e300'], "'Dbar'"),
    'a speed of 1e300 rad/s': (['stability', '--set', 'omega=1e300'], "'omega'",
                               '[0, 100000] rad/s'),
    'wbar of 1e300': (['stability', '--set', 'wbar=1e300'], "'wbar'", 'omega in'),
    'wbar of 1e-300': (['stability', '--set', 'wbar=1e-300'], "'omega'", 'RK4 steps'),
    'a speed of 0.01 rad/s': (['stability', '--set', 'omega=0.01'], "'omega' = 0.01",
                              'at least about', 'limit of 100000'),
    'a speed of 5e-324 rad/s': (['stability', '--set', 'omega=5e-324'], "'omega'"),
    'the largest damping at wbar 2': (['stability', '--set', 'wbar=2', '--set', 'c=2.5e6'],
                                      "'omega'", 'RK4 steps'),
    'the largest drag at wbar 2': (['stability', '--set', 'wbar=2', '--set', 'D=5'],
                                   "'omega'", 'RK4 steps'),
    'freqs of a stiffness of 1e300': (['freqs', '--set', 'k=1e300'], "'k'"),
    'freqs of masses of 1e-300': (['freqs', '--set', 'M=1e-300', '--set', 'M_P=1e-300'],
                                  "'M_P' = 1e-300"),
    'freqs of a deck width of 1e300': (['freqs', '--set', 'a=1e300'], "'a'"),
    'a map range up to 1e300': (MAP + ['--range-x', '0.2:1e300'], '--range-x',
                                'wbar = 1e+300'),
    'a map of a stiffness of 1e10': (MAP + ['--set', 'k=1e10'], "error: parameter 'k'"),
    'a map zeta range up to 1e300': (['map', '--x', 'zeta', '--y', 'mbar', '--res', '2x2',
                                      '--set', 'wbar=2', '--range-x', '0:1e300', '--out',
                                      'm.png'], '--range-x', "'zeta'"),
    'a map from wbar 0': (MAP + ['--range-x', '0:3'], "slowest speed", '--range-x'),
    'a run of 1e300 s': (['run', '--duration', '1e300', '--no-progress'], "'duration'",
                         '[0.001, 10000] s', '100000000 steps'),
    'a run of 1e5 s': (['run', '--duration', '1e5', '--no-progress'], "'duration'"),
    'a run of 6000 s at 20 kHz': (['run', '--duration', '6000', '--set',
                                  'integration_rate_hz=20000', '--no-progress'],
                                 '[0.001, 5000] s'),
}


@pytest.mark.parametrize('case', sorted(EXTREME_CASES))
def test_an_extreme_value_is_a_range_error_before_any_work(tmp_path, capsys, monkeypatch,
                                                           case):
    monkeypatch.chdir(tmp_path)
    argv, *needles = EXTREME_CASES[case]
    line = refused(capsys, argv)
    for needle in needles:
        assert needle in line
    assert list(tmp_path.iterdir()) == []


def test_the_ranges_keep_the_papers_drives_valid(capsys):
    """Table 1, metal washers, heavy balls of Fig. 8 and the stiff drive of the blow-up test."""
    for argv in (['stability', '--set', 'wbar=0.2'], ['stability', '--set', 'wbar=3.5'],
                 ['stability', '--set', 'wbar=2', '--set', 'mbar=2.5'],
                 ['freqs', '--set', 'k=1e9'], ['freqs', '--set', 'c=0.66']):
        assert main(argv) == 0, capsys.readouterr().err
        assert capsys.readouterr().err == ''


# ---- outputs that exist, flags naming a swept axis -----------------------------------------

def _bag(path):
    assert main(['run', '--duration', '0.01', '--no-progress', '--out', str(path)]) == 0
    return sorted(p.name for p in path.iterdir())


def test_run_out_onto_an_existing_bag_needs_overwrite(tmp_path, capsys):
    bag = tmp_path / 'bag'
    before = _bag(bag)
    mcap = (bag / 'bag_0.mcap').read_bytes()
    capsys.readouterr()
    line = refused(capsys, ['run', '--duration', '0.02', '--no-progress', '--out', str(bag)])
    assert '--out' in line and '--overwrite' in line
    assert (bag / 'bag_0.mcap').read_bytes() == mcap
    assert main(['run', '--duration', '0.02', '--no-progress', '--out', str(bag),
                 '--overwrite']) == 0
    assert sorted(p.name for p in bag.iterdir()) == before
    assert (bag / 'bag_0.mcap').read_bytes() != mcap
    assert sorted(p.name for p in tmp_path.iterdir()) == ['bag']


ROSBAG_METADATA = ('rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n'
                   '  custom_data: {note: mine}\n')
"""A metadata.yaml another tool (rosbag2, a user) wrote: a bag, but not this package's."""


@pytest.mark.parametrize('case', ['two recordings', 'a recording without metadata',
                                  'a foreign file', 'a file', "a user's metadata and mcap",
                                  "another tool's bag"])
def test_run_overwrite_replaces_one_bag_only(tmp_path, capsys, case):
    """Only a bag this package wrote (its metadata says so) is replaced; anything else: exit 2,
    one line, every file where it was."""
    out = tmp_path / 'recs'
    if case == 'a file':
        out.write_text('x')
    else:
        out.mkdir()
        names = {'two recordings': ['metadata.yaml', 'a.mcap', 'b.mcap'],
                 'a recording without metadata': ['a.mcap'],
                 'a foreign file': ['metadata.yaml', 'a.mcap', 'notes.txt'],
                 "a user's metadata and mcap": ['metadata.yaml', 'flight.mcap'],
                 "another tool's bag": ['metadata.yaml', 'recs_0.mcap']}[case]
        for name in names:
            (out / name).write_text(ROSBAG_METADATA if case == "another tool's bag"
                                    and name == 'metadata.yaml' else name)
    before = sorted(tmp_path.rglob('*'))
    line = refused(capsys, ['run', '--duration', '0.01', '--no-progress', '--out', str(out),
                            '--overwrite'])
    assert f'--out {out}' in line and 'not replacing it' in line
    assert sorted(tmp_path.rglob('*')) == before


@pytest.mark.parametrize('argv, needle', [
    (['--x', 'wbar', '--y', 'mbar', '--set', 'wbar=2'], '--set wbar'),
    (['--x', 'wbar', '--y', 'mbar', '--set', 'omega=300'], '--set omega'),
    (['--x', 'zeta', '--y', 'mbar', '--set', 'wbar=2', '--set', 'mbar=0.1'], '--set mbar'),
])
def test_map_refuses_a_fixed_value_of_a_swept_axis(tmp_path, capsys, monkeypatch, argv, needle):
    monkeypatch.chdir(tmp_path)
    line = refused(capsys, ['map', *argv, '--res', '2x2', '--out', 'm.png', '--no-progress'])
    assert needle in line and 'axis' in line
    assert list(tmp_path.iterdir()) == []


# ---- sweep specs ---------------------------------------------------------------------------

SPEC = """\
scenario: p3
parameters:
{parameters}
samples: 2
{extra}compute:
  stability: {stability}
"""

SPEC_CASES = {
    'a normal whose mean is outside its bounds': (
        '  k: {dist: normal, mean: 5000, std: 100, low: 3500, high: 4500}', '', '{wbar: [2]}',
        "'parameters.k.mean' = 5000", '[3500, 4500]'),
    'a normal wider than its bounds': (
        '  k: {dist: normal, mean: 4000, std: 5000, low: 3500, high: 4500}', '',
        '{wbar: [2]}', "'parameters.k.std'", 'uniform'),
    'a normal of no spread': (
        '  k: {dist: normal, mean: 4000, std: 1.0e-300, low: 3500, high: 4500}', '',
        '{wbar: [2]}', "'parameters.k.std'", 'round-off'),
    'a parameter named twice': (
        '  k: {dist: uniform, low: 3500, high: 4500}\n  k: {dist: uniform, low: 1, high: 2}',
        '', '{wbar: [2]}', "'k' appears twice", 'line 4'),
    'an SI name and its Eq. 39 twin': (
        '  c: {dist: uniform, low: 0.5, high: 1}\n  zeta: {dist: uniform, low: 0.01, '
        'high: 0.02}', '', '{wbar: [2]}', "'parameters.c'", 'not both'),
    'an operating speed of 1e300': (
        '  k: {dist: uniform, low: 3500, high: 4500}', 'operating_wbar: 1.0e+300\n',
        '{wbar: [2]}', "'operating_wbar'"),
    'an operating omega of 1e300': (
        '  k: {dist: uniform, low: 3500, high: 4500}', 'operating_omega: 1.0e+300\n',
        '{wbar: [2]}', "'operating_omega'", '100000'),
    'a stability range up to 1e300': (
        '  k: {dist: uniform, low: 3500, high: 4500}', '',
        '{range: {wbar: [1, 1.0e+300], points: 3}}', "'compute.stability.range.wbar'"),
    'a run step of 1e-12 s': (
        '  k: {dist: uniform, low: 3500, high: 4500}', '',
        '{wbar: [2]}\n  run: {duration: 1.0, dt: 1.0e-12}', "'compute.run.dt' = 1e-12",
        '100000000 steps'),
    'a run step of 5e-324 s': (
        '  k: {dist: uniform, low: 3500, high: 4500}', '', '{wbar: [2]}\n  run: {dt: 5e-324}',
        "'compute.run.dt'"),
    'a stability speed of 1e300': (
        '  k: {dist: uniform, low: 3500, high: 4500}', '', '{omega: [1.0e+300]}',
        "'compute.stability.omega'"),
}


@pytest.mark.parametrize('case', sorted(SPEC_CASES))
def test_a_bad_sweep_spec_is_one_line_naming_the_field(tmp_path, capsys, case):
    parameters, extra, stability, *needles = SPEC_CASES[case]
    spec = tmp_path / 'spec.yaml'
    spec.write_text(SPEC.format(parameters=parameters, extra=extra, stability=stability))
    out = tmp_path / 'out'
    line = refused(capsys, ['sweep', str(spec), '--out', str(out), '--serial',
                            '--no-progress'])
    for needle in needles:
        assert needle in line
    assert not out.exists()


def test_a_sweep_drive_over_the_step_limit_names_the_stability_field(tmp_path, capsys):
    spec = tmp_path / 'spec.yaml'
    spec.write_text(SPEC.format(parameters='  c: {dist: uniform, low: 1.0e+5, high: 2.0e+6}',
                                extra='', stability='{wbar: [2]}'))
    line = refused(capsys, ['sweep', str(spec), '--out', str(tmp_path / 'out'), '--serial',
                            '--no-progress'])
    assert "'compute.stability'" in line and 'a drawn drive' in line
    assert not list((tmp_path / 'out').glob('part-*'))


# ---- sweep directories that no sweep wrote -------------------------------------------------

def _parquet(path, metadata=None):
    import pyarrow as pa
    import pyarrow.parquet as pq
    table = pa.table({'x': [1.0, 2.0]}).replace_schema_metadata(metadata)
    pq.write_table(table, path)


@pytest.mark.parametrize('case', ['garbage', 'not a sweep', 'empty file'])
def test_sweep_report_of_a_foreign_part_is_one_line_naming_it(tmp_path, capsys, case):
    sweep = tmp_path / 'sweep'
    sweep.mkdir()
    part = sweep / 'part-00000.parquet'
    if case == 'garbage':
        part.write_bytes(b'PAR1' + bytes(range(256)) * 8 + b'PAR1')
    elif case == 'empty file':
        part.write_bytes(b'')
    else:
        _parquet(part)
    line = refused(capsys, ['sweep-report', str(sweep), '--out', str(tmp_path / 'report')])
    assert str(part) in line
    assert not (tmp_path / 'report').exists()


@pytest.mark.parametrize('text', ['{"spec": ', '[1, 2]', '\xff\xfe', '{"spec": 3}'])
def test_resume_from_a_corrupt_manifest_is_one_line_naming_it(tmp_path, capsys, text):
    spec = tmp_path / 'spec.yaml'
    spec.write_text(SPEC.format(parameters='  k: {dist: uniform, low: 3500, high: 4500}',
                                extra='', stability='{wbar: [2]}'))
    out = tmp_path / 'out'
    out.mkdir()
    (out / '_sweep.json').write_bytes(text.encode('latin-1'))
    line = refused(capsys, ['sweep', str(spec), '--out', str(out), '--serial', '--resume',
                            '--no-progress'])
    assert '_sweep.json' in line and 'not a sweep manifest' in line
    assert sorted(p.name for p in out.iterdir()) == ['_sweep.json']


def test_a_repeated_key_in_a_parameter_file_is_refused(tmp_path, capsys):
    config = tmp_path / 'drive.yaml'
    config.write_text('/**:\n  ros__parameters:\n    drive:\n      k: 4000\n      k: 5000\n')
    line = refused(capsys, ['freqs', '--config', str(config)])
    assert str(config) in line and "'k' appears twice" in line


def test_a_parameter_file_nested_too_deep_is_refused_naming_the_key(tmp_path, capsys):
    config = tmp_path / 'drive.yaml'
    deep = ''.join('  ' * (i + 2) + f'k{i}:\n' for i in range(40))
    config.write_text('/**:\n  ros__parameters:\n' + deep + '  ' * 42 + 'x: 1\n')
    line = refused(capsys, ['freqs', '--config', str(config)])
    assert str(config) in line and 'nested deeper than 32 levels' in line
    assert "under the key '/**.ros__parameters ... k28.k29'" in line and 'line 33' in line


def test_numpy_warnings_are_errors_inside_abb_sim_only(capsys, monkeypatch):
    """A computation that warns ends in one line (exit 1); the caller's filters come back."""
    import warnings

    import numpy as np

    from abb_ros.commands import freqs

    def overflow(_args):
        return {'x': float(np.float64(1e300) * np.float64(1e300))}

    monkeypatch.setattr(freqs, 'run', overflow)
    line = refused(capsys, ['freqs'], code=1)
    assert 'numerically' in line and 'overflow' in line
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        np.float64(1e300) * np.float64(1e300)
    assert caught and issubclass(caught[0].category, RuntimeWarning)



TINY_SWEEP = """\
name: {name}
scenario: p3
parameters:
  k: {{dist: uniform, low: 3500, high: 4500}}
samples: 4
sampling: {{method: random, seed: {seed}}}
partition_size: 2
compute:
  stability: {{wbar: [2]}}
"""


@pytest.fixture(scope='module')
def two_sweeps(tmp_path_factory):
    """Two small sweeps of the same columns (different seeds): directories a and b."""
    root = tmp_path_factory.mktemp('sweeps')
    for name, seed in (('a', 1), ('b', 2)):
        spec = root / f'{name}.yaml'
        spec.write_text(TINY_SWEEP.format(name=name, seed=seed))
        assert main(['sweep', str(spec), '--out', str(root / name), '--serial',
                     '--no-progress']) == 0
    return root


def _copy_sweep(src, dst):
    import shutil
    shutil.copytree(src, dst)
    return dst


@pytest.mark.parametrize('case', ['a part of another sweep', 'a part copied in twice',
                                  'a part of other columns'])
def test_sweep_report_refuses_parts_that_are_not_of_this_sweep(two_sweeps, tmp_path, capsys,
                                                               case):
    """The sweep's identity (its spec) and columns are checked across the part files: one
    line naming the file, exit 2, no report (never 8 samples of 6 planned)."""
    import pyarrow.parquet as pq
    sweep = _copy_sweep(two_sweeps / 'a', tmp_path / 'a')
    if case == 'a part of another sweep':
        (sweep / 'part-00002.parquet').write_bytes(
            (two_sweeps / 'b' / 'part-00001.parquet').read_bytes())
    elif case == 'a part copied in twice':
        (sweep / 'part-00002.parquet').write_bytes((sweep / 'part-00001.parquet').read_bytes())
    else:
        table = pq.read_table(sweep / 'part-00001.parquet')
        pq.write_table(table.drop_columns([table.column_names[-1]]),
                       sweep / 'part-00001.parquet')
    capsys.readouterr()
    line = refused(capsys, ['sweep-report', str(sweep), '--out', str(tmp_path / 'r')])
    needle = {'a part of another sweep': 'part-00002.parquet: a part of another sweep',
              'a part copied in twice': 'two part files',
              'a part of other columns': 'part-00001.parquet: its columns differ'}[case]
    assert needle in line
    assert not (tmp_path / 'r').exists()


def test_sweep_report_onto_an_existing_file_is_exit_2(two_sweeps, tmp_path, capsys):
    """--out naming a file: a usage error (exit 2, one line), the file untouched."""
    out = tmp_path / 'report'
    out.write_text('mine')
    line = refused(capsys, ['sweep-report', str(two_sweeps / 'a'), '--out', str(out)])
    assert f'--out {out}' in line and 'not a directory' in line
    assert out.read_text() == 'mine'


# ---- basin directories that no study of this spec wrote, and outputs the system refuses --------

BASIN = ['basin', '--res', '2x2', '--duration', '0.1', '--partition-size', '2', '--serial',
         '--no-progress']


@pytest.fixture(scope='module')
def two_studies(tmp_path_factory):
    """Two finished 2 x 2 basin studies of different seeds' drives: a and b (2 parts each)."""
    root = tmp_path_factory.mktemp('studies')
    for name, k in (('a', '4000'), ('b', '4100')):
        assert main([*BASIN, '--set', f'k={k}', '--out', str(root / name)]) == 0
    return root


@pytest.mark.parametrize('case', ['a part of another study', 'a part copied in twice',
                                  'a part copied under the next name'])
def test_basin_resume_refuses_parts_of_another_study_in_one_line(two_studies, tmp_path, capsys,
                                                                 case):
    """--resume on a directory holding a foreign or duplicated part file: exit 2 and one line
    naming the file, before any work (never a SweepFileError traceback after it)."""
    study = _copy_sweep(two_studies / 'a', tmp_path / 'a')
    parts = study / 'parts'
    if case == 'a part of another study':
        (parts / 'part-00001.parquet').write_bytes(
            (two_studies / 'b' / 'parts' / 'part-00001.parquet').read_bytes())
        needle = 'part-00001.parquet: a part of another sweep'
    elif case == 'a part copied in twice':
        (parts / 'part-00001.parquet').write_bytes(
            (parts / 'part-00000.parquet').read_bytes())
        needle = 'part-00001.parquet: holds partition 0'
    else:
        (parts / 'part-00001.parquet').rename(parts / 'part-00002.parquet')
        (parts / 'part-00001.parquet').write_bytes(
            (parts / 'part-00000.parquet').read_bytes())
        needle = 'part-00001.parquet'
    capsys.readouterr()
    before = sorted(p.name for p in parts.iterdir())
    line = refused(capsys, [*BASIN, '--set', 'k=4000', '--out', str(study), '--resume'])
    assert needle in line and '--resume' in line, line
    assert sorted(p.name for p in parts.iterdir()) == before   # nothing computed or removed


def test_sweep_resume_refuses_a_part_copied_in_twice(two_sweeps, tmp_path, capsys):
    sweep = _copy_sweep(two_sweeps / 'a', tmp_path / 'a')
    (sweep / 'part-00001.parquet').write_bytes((sweep / 'part-00000.parquet').read_bytes())
    line = refused(capsys, ['sweep', str(two_sweeps / 'a.yaml'), '--out', str(sweep),
                            '--resume', '--serial', '--no-progress'])
    assert 'part-00001.parquet: holds partition 0' in line


def _unwritable_out(tmp_path):
    """An --out this user cannot create: below /sys for root, a read-only directory else."""
    import os
    if os.geteuid() == 0:
        if not os.path.isdir('/sys/kernel'):
            pytest.skip('no /sys to refuse root a directory')
        return '/sys/abb_sim_out'
    ro = tmp_path / 'ro'
    ro.mkdir()
    ro.chmod(0o555)
    return str(ro / 'out')


@pytest.mark.parametrize('command', ['basin', 'sweep'])
def test_an_out_the_system_refuses_is_bad_input_exit_2(two_sweeps, tmp_path, capsys, command):
    out = _unwritable_out(tmp_path)
    argv = ([*BASIN, '--out', out] if command == 'basin' else
            ['sweep', str(two_sweeps / 'a.yaml'), '--out', out, '--serial', '--no-progress'])
    line = refused(capsys, argv)
    assert f'--out {out}: cannot be written' in line, line

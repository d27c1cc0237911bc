"""Every bad input of `abb-sim`, one line: exit code 2 naming what is wrong and what is valid;
a runtime failure (full disk, a blown-up state) exit code 1; nothing left that looks like success.

Table-driven over the classes a fuzz of the command line found, run in-process through
``cli.main(argv)`` on real files. Read-only and full file systems are real tmpfs mounts (this
runs as root, which chmod does not stop); where mounting is not allowed those cases are skipped.
"""

import json
import subprocess
import time
from pathlib import Path

import pytest

from abb_ros.cli import main
from abb_ros.io.bag.writer import INCOMPLETE_KEY, BagWriter

ALIAS_BOMB = ('a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n'
              + ''.join(f'{c}: &{c} [*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p}]\n'
                        for p, c in zip('abcdefgh', 'bcdefghi')))
"""About 1 KB of YAML that expands to 9**9 strings when walked ("billion laughs")."""


def under(key, text):
    """``text`` indented as the value of ``key``."""
    return f'{key}:\n' + ''.join(f'  {line}\n' for line in text.splitlines())


TABLE1 = '/**:\n  ros__parameters:\n    drive:\n'
DECK_OK = '[0.3e-3, 0.3e-3, 0.3e-3, 0, 0, 0]'


@pytest.fixture(scope='module', autouse=True)
def imported():
    """Import every command module once, so that time limits measure the loading alone."""
    from abb_ros import cli
    for name in cli.SUBCOMMANDS:
        cli._load(name)
    import abb_ros.app.headless  # noqa: F401
    import abb_ros.plots.time_response  # noqa: F401


def within_a_second(case, t0):
    """Files built to hang a loader (alias bomb, deep nesting, size) are refused at once; the
    largest file accepted (64 KB) is read in seconds."""
    if any(word in case for word in ('alias', 'nested', 'size')):
        assert time.perf_counter() - t0 < 1.0
    elif '12000' in case:
        assert time.perf_counter() - t0 < 5.0


def one_error_line(capsys, code, expected_code):
    """The single stderr line of a refused command (stdout empty)."""
    out = capsys.readouterr()
    lines = out.err.strip().splitlines()
    assert code == expected_code, out.err
    assert len(lines) == 1, out.err
    assert 'Traceback' not in out.err and out.out == ''
    return lines[0]


def write(path: Path, text) -> str:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return str(path)


# ---- --config: parameter files -------------------------------------------------------------

CONFIG_CASES = {
    'missing file': (None, 'no such file'),
    'a directory': ('<dir>', 'is a directory'),
    'malformed YAML': ('/**: {ros__parameters: [1, 2\n', 'malformed YAML'),
    'a list where a mapping belongs': ('- 1\n- 2\n', 'the document is a list'),
    'ros__parameters a list': ('/**:\n  ros__parameters: [1, 2]\n', 'no drive parameters'),
    'alias bomb': (TABLE1 + '      k: 4000\n' + ALIAS_BOMB, 'aliases'),
    'nested 10000 deep': ('[' * 10000 + ']' * 10000, 'nested deeper than'),
    'over the size cap': ('# ' + 'x' * (1 << 20) + '\n', 'larger than'),
    'a list of 12000 numbers': ('a: [' + '1.5, ' * 12000 + ']\n', 'no drive parameters'),
    'not UTF-8': (b'/**: {ros__parameters: {drive: {k: \xff}}}\n', 'not UTF-8'),
    'a number key': (TABLE1 + '      1: 2\n', "'1'"),
    'an unknown parameter': (TABLE1 + '      kk: 2\n', "'kk'"),
    'text for a number': (TABLE1 + '      k: abc\n', "'k' = 'abc'"),
    'a negative stiffness': (TABLE1 + '      k: -1\n', '[0.003972, 3.972e+09] N/m'),
}


@pytest.mark.parametrize('command', [
    ['freqs'], ['stability', '--set', 'wbar=2'], ['run', '--duration', '0.01', '--no-progress'],
    ['map', '--x', 'wbar', '--y', 'mbar', '--res', '2x2', '--out', 'never.png']])
@pytest.mark.parametrize('case', sorted(CONFIG_CASES))
def test_a_bad_config_file_is_one_line_naming_the_file(tmp_path, capsys, monkeypatch, case,
                                                       command):
    monkeypatch.chdir(tmp_path)
    text, needle = CONFIG_CASES[case]
    path = tmp_path / 'config.yaml'
    if text == '<dir>':
        path.mkdir()
    elif text is not None:
        write(path, text)
    t0 = time.perf_counter()
    line = one_error_line(capsys, main([*command, '--config', str(path)]), 2)
    within_a_second(case, t0)
    assert str(path) in line and needle in line
    assert not (tmp_path / 'never.png').exists()


# ---- --scenario: scenario files ------------------------------------------------------------

SCENARIO_CASES = {
    'a number key': ('1: x\n', 'keys must be text'),
    'initial a list': ('initial: [1, 2]\n', "'scenario.initial'"),
    'initial deck a number': ('initial: {deck: 5}\n', "'scenario.initial.deck' = 5"),
    'commands a number': ('spindle: {model: motor, commands: 5}\n', 'scenario.spindle.commands'),
    'commands with a constant spindle': ('spindle: {commands: 5}\n', 'model: motor'),
    'alias bomb under name': (under('name', ALIAS_BOMB), 'aliases'),
    'alias bomb under description': (under('description', ALIAS_BOMB), 'aliases'),
    'an unknown top-level key': ('durration: 3\n', 'description, drive, duration'),
    'an unknown key under initial': (f'initial: {{deck: {DECK_OK}, velocity: 1}}\n',
                                     "'scenario.initial.velocity'"),
    'an unknown key in a command': ('spindle: {model: motor, commands: [{t: 1, wbar: 2, x: 1}]}\n',
                                    "'scenario.spindle.commands[0].x'"),
    'an unknown key under spindle': ('spindle: {model: motor, gain: 2}\n', 'max_accel, model'),
    'an unknown drive parameter': ('drive: {kk: 1}\n', "'scenario.drive.kk'"),
    'a deck displaced 1 m': ('initial: {deck: [1, 0, 0, 0, 0, 0]}\n',
                             "'scenario.initial.deck[0] (X)' = 1.0 is invalid: valid range is a "
                             'finite number in [-0.02, 0.02] m'),
    'a deck tilted 1 rad': ('initial: {deck: [0, 0, 0, 0, 1, 0]}\n',
                            'deck[4] (beta)'),
    'a deck of 5 numbers': ('initial: {deck: [0, 0, 0, 0, 0]}\n', 'a list of 6 numbers'),
    'phi_deg of the wrong length': ('initial: {phi_deg: [1, 2, 3]}\n', 'n = 2'),
    'a name that is a list': ('name: [1, 2]\n', "'scenario.name'"),
    'a duration that is text': ('duration: ten\n', "'scenario.duration'"),
    'a duration of a microsecond': ('duration: 1.0e-6\n', '[0.001, 10000] s'),
    'a command without t': ('spindle: {model: motor, commands: [{wbar: 2}]}\n', '{t: seconds'),
    'a negative tau': ('spindle: {model: motor, tau: -1}\n', "'scenario.spindle.tau'"),
    'a drive parameter that is text': ('drive: {k: stiff}\n', "'k' = 'stiff'"),
    'a setting out of range': ('set: {zeta: -1}\n', "'zeta' = -1"),
    'malformed YAML': ('set: {wbar: [1, 2}\n', 'malformed YAML'),
    'a list document': ('- p3\n', 'a mapping with keys'),
    'a directory': ('<dir>', 'is a directory'),
    'a missing file': (None, 'no such file'),
}


@pytest.mark.parametrize('case', sorted(SCENARIO_CASES))
def test_a_bad_scenario_file_is_one_line_naming_the_field(tmp_path, capsys, case):
    text, needle = SCENARIO_CASES[case]
    path = tmp_path / 'scenario.yaml'
    if text == '<dir>':
        path.mkdir()
    elif text is not None:
        write(path, text)
    out = tmp_path / 'bag'
    t0 = time.perf_counter()
    code = main(['run', '--scenario', str(path), '--out', str(out), '--no-progress'])
    within_a_second(case, t0)
    line = one_error_line(capsys, code, 2)
    assert needle in line and str(path) in line
    assert not out.exists()


def test_the_shipped_scenarios_pass_the_schema():
    from abb_ros.io.files.scenario import list_scenarios, load_scenario
    names = list_scenarios()
    assert len(names) >= 7
    for name in names:
        assert load_scenario(name).duration > 0


# ---- command-line values -------------------------------------------------------------------

ARGV_CASES = {
    'a duration of 1 ns': (['run', '--duration', '1e-9'], "'duration' = 1e-09",
                           '[0.001, 10000] s'),
    'a duration shorter than a publish period': (['run', '--duration', '0.0005'],
                                                 '[0.001, 10000] s'),
    'a duration of nan': (['run', '--duration', 'nan'], "'duration'"),
    'a duration of inf': (['run', '--duration', 'inf'], "'duration'"),
    'a duration that is text': (['run', '--duration', 'ten'], '--duration', 'float'),
    'an unknown command': (['fly'], "invalid choice: 'fly'"),
    'a missing --x': (['map', '--y', 'mbar', '--out', 'x.png'], '--x'),
    'a --set without =': (['stability', '--set', 'wbar'], 'key=value'),
    'an unknown scenario name': (['run', '--scenario', 'p9'], "'scenario'", 'p3'),
    'a map --data that is neither npz nor csv': (
        ['map', '--x', 'wbar', '--y', 'mbar', '--res', '2x2', '--out', 'm.png',
         '--data', 'm.txt'], '--data m.txt', '.csv, .npz'),
    'a map --out that is not an image': (
        ['map', '--x', 'wbar', '--y', 'mbar', '--res', '2x2', '--out', 'm.txt'], '.png'),
    'a plot --R of nan': (['plot', 'bag', '--out', 'figs', '--R', 'nan'], '--R'),
}


@pytest.mark.parametrize('case', sorted(ARGV_CASES))
def test_a_bad_command_line_value_is_one_line(tmp_path, capsys, monkeypatch, case):
    monkeypatch.chdir(tmp_path)
    argv, *needles = ARGV_CASES[case]
    line = one_error_line(capsys, main(argv), 2)
    for needle in needles:
        assert needle in line
    assert list(tmp_path.iterdir()) == []


# ---- bags given to `plot` ------------------------------------------------------------------

def _json_mcap(path):
    from mcap.writer import Writer
    with open(path, 'wb') as f:
        w = Writer(f)
        w.start()
        schema = w.register_schema('geometry_msgs/msg/PoseStamped', 'jsonschema', b'{}')
        channel = w.register_channel('/deck/pose', 'json', schema)
        w.add_message(channel, 1, json.dumps({'pose': {}}).encode(), 1)
        w.finish()


def test_plot_of_a_json_encoded_mcap_is_one_line(tmp_path, capsys):
    _json_mcap(tmp_path / 'json.mcap')
    line = one_error_line(capsys, main(['plot', str(tmp_path / 'json.mcap'), '--out',
                                        str(tmp_path / 'figs')]), 2)
    assert "encoded as 'json'" in line and 'CDR' in line
    assert not (tmp_path / 'figs').exists()


@pytest.mark.parametrize('case', ['garbage mcap', 'alias bomb metadata', 'metadata a list',
                                  'no mcap file'])
def test_plot_of_a_broken_bag_is_one_line(tmp_path, capsys, case):
    bag = tmp_path / 'bag'
    bag.mkdir()
    if case == 'garbage mcap':
        bag = Path(write(tmp_path / 'x.mcap', b'\x89MCAP0\r\n' + bytes(range(256)) * 4))
    elif case == 'alias bomb metadata':
        write(bag / 'metadata.yaml', under('rosbag2_bagfile_information', ALIAS_BOMB))
    elif case == 'metadata a list':
        write(bag / 'metadata.yaml', 'rosbag2_bagfile_information: [1, 2]\n')
    t0 = time.perf_counter()
    line = one_error_line(capsys, main(['plot', str(bag), '--out', str(tmp_path / 'figs')]), 2)
    within_a_second(case, t0)
    assert str(bag) in line
    assert not (tmp_path / 'figs').exists()


# ---- outputs: under a file, read-only, full ------------------------------------------------

def _mount_tmpfs(where: Path, size='64k', read_only=False):
    where.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(['mount', '-t', 'tmpfs', '-o', f'size={size}', 'tmpfs', str(where)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f'cannot mount a tmpfs here: {done.stderr.strip()}')
    if read_only:
        subprocess.run(['mount', '-o', 'remount,ro', str(where)], check=True)


@pytest.fixture
def read_only_dir(tmp_path):
    """A read-only file system (remounted tmpfs): root cannot write there either."""
    disk = tmp_path / 'ro'
    _mount_tmpfs(disk, read_only=True)
    yield disk
    subprocess.run(['umount', '-l', str(disk)], check=False)


@pytest.fixture
def full_dir(tmp_path):
    """A 64 KiB tmpfs filled to the last byte."""
    disk = tmp_path / 'full'
    _mount_tmpfs(disk)
    try:
        with open(disk / 'filler', 'wb', buffering=0) as f:
            while True:
                f.write(b'\0' * 4096)
    except OSError:
        pass
    yield disk
    subprocess.run(['umount', '-l', str(disk)], check=False)


@pytest.fixture
def small_disk(tmp_path):
    """A 64 KiB tmpfs, empty: a bag of a few seconds does not fit."""
    disk = tmp_path / 'small'
    _mount_tmpfs(disk)
    yield disk
    subprocess.run(['umount', '-l', str(disk)], check=False)


def _plot_bag(tmp_path):
    bag = tmp_path / 'p3'
    assert main(['run', '--duration', '0.05', '--out', str(bag), '--no-progress']) == 0
    return bag


def _argv(command, out, tmp_path):
    if command == 'run':
        return ['run', '--duration', '0.01', '--no-progress', '--out', str(out / 'bag')]
    if command == 'map':
        return ['map', '--x', 'wbar', '--y', 'mbar', '--res', '3x2', '--no-progress',
                '--out', str(out / 'm.png')]
    return ['plot', str(_plot_bag(tmp_path)), '--out', str(out / 'figs')]


@pytest.mark.parametrize('command', ['run', 'map', 'plot'])
def test_out_under_a_regular_file_is_one_line(tmp_path, capsys, command):
    blocker = Path(write(tmp_path / 'afile', 'x'))
    argv = _argv(command, blocker, tmp_path)
    capsys.readouterr()
    line = one_error_line(capsys, main(argv), 2)
    assert '--out' in line and 'not a directory' in line.lower()
    assert blocker.read_text() == 'x'


@pytest.mark.parametrize('command', ['run', 'map', 'plot'])
def test_out_on_a_read_only_file_system_is_one_line(tmp_path, capsys, read_only_dir, command):
    argv = _argv(command, read_only_dir, tmp_path)
    capsys.readouterr()
    line = one_error_line(capsys, main(argv), 2)
    assert '--out' in line and str(read_only_dir) in line
    assert ('Read-only' in line or 'not writable' in line)
    assert list(read_only_dir.iterdir()) == []


@pytest.mark.parametrize('command', ['run', 'map', pytest.param('plot', marks=pytest.mark.slow)])
def test_out_on_a_full_disk_fails_in_one_line_and_leaves_nothing(tmp_path, capsys, full_dir,
                                                                   command):
    argv = _argv(command, full_dir, tmp_path)
    capsys.readouterr()
    line = one_error_line(capsys, main(argv), 1)
    assert 'No space left on device' in line
    assert [p.name for p in full_dir.iterdir()] == ['filler']


def test_a_bag_that_outgrows_the_disk_is_removed(small_disk, capsys):
    out = small_disk / 'bag'
    line = one_error_line(capsys, main(['run', '--duration', '3', '--no-progress', '--out',
                                        str(out)]), 1)
    assert 'No space left on device' in line and 'removed' in line
    assert not out.exists()


def test_a_run_that_blows_up_keeps_its_bag_marked_incomplete(tmp_path, capsys):
    from abb_ros.io.bag.reader import read_bag
    from abb_ros.io.files.safe_yaml import load_file
    out = tmp_path / 'stiff'
    line = one_error_line(capsys, main(['run', '--set', 'k=1e9', '--duration', '0.1', '--out',
                                        str(out), '--no-progress']), 1)
    assert 'simulation stopped' in line and 'envelope' in line
    info = load_file(out / 'metadata.yaml')['rosbag2_bagfile_information']
    assert 'envelope' in info['custom_data'][INCOMPLETE_KEY]
    held = sum(1 for _ in read_bag(out))
    assert info['message_count'] == held > 0


def test_metadata_never_counts_messages_of_a_chunk_that_did_not_reach_the_file(tmp_path):
    """A disk that refuses the second chunk: metadata.yaml counts the first chunk only."""
    from abb_ros.io.bag.reader import read_bag
    from abb_ros.io.bag.writer import BagWriteError
    from abb_ros.io.files.safe_yaml import load_file

    class Disk:
        def __init__(self, path):
            self.f = open(path, 'xb', buffering=0)
            self.chunks = 0

        def write(self, data):
            if data[:1] == b'\x06':
                self.chunks += 1
                if self.chunks == 2:
                    raise OSError(28, 'No space left on device')
            return self.f.write(data)

        def truncate(self, size):
            return self.f.truncate(size)

        def close(self):
            self.f.close()

    bag = BagWriter(tmp_path / 'bag', chunk_size=1024, compression='none', opener=Disk)
    bag.add_topic('spindle/speed_cmd', 'std_msgs/msg/Float64')
    written = 0
    with pytest.raises(BagWriteError):
        for i in range(1000):
            bag.write('spindle/speed_cmd', b'\0\1\0\0' + bytes(8), i)
            written += 1
    info = load_file(tmp_path / 'bag' / 'metadata.yaml')['rosbag2_bagfile_information']
    held = sum(1 for _ in read_bag(tmp_path / 'bag'))
    assert 0 < held < written
    assert info['message_count'] == held
    assert info['topics_with_message_count'][0]['message_count'] == held
    assert 'No space left' in info['custom_data'][INCOMPLETE_KEY]


def test_every_yaml_file_is_read_through_safe_yaml():
    """One loader with limits: no other module of the package parses YAML itself."""
    package = Path(__file__).resolve().parents[2] / 'abb_ros'
    offenders = [str(p.relative_to(package)) for p in package.rglob('*.py')
                 if p.name != 'safe_yaml.py' and any(
                     call in p.read_text() for call in ('yaml.safe_load', 'yaml.load(',
                                                        'yaml.full_load', 'yaml.unsafe_load'))]
    assert offenders == []


@pytest.mark.parametrize('text, needle', [(ALIAS_BOMB, 'aliases'),
                                          ('[' * 60000, 'nested deeper than'),
                                          ('a:\n' + ''.join(' ' * i + f'k{i}:\n'
                                                            for i in range(1, 40)), 'nested')])
def test_without_libyaml_the_same_limits_hold(monkeypatch, text, needle):
    from abb_ros.io.files import safe_yaml
    monkeypatch.setattr(safe_yaml, '_LOADER', safe_yaml._PyLoader)
    t0 = time.perf_counter()
    with pytest.raises(safe_yaml.YamlFileError, match=needle):
        safe_yaml.load_text(text)
    assert time.perf_counter() - t0 < 1.0

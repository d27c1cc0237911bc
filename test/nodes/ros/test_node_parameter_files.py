"""Parameter files and ``-p`` overrides a node would silently ignore end it with one line.

rclpy gives a node only the parameters it declares: an unknown key, a misspelt node name, a
file of plain text or a key given twice would otherwise start the node on defaults (the
default drive instead of the intended one). Each case: exit code 2, one line on stderr naming
the file (or ``-p``) and the key, no traceback, for every node executable. The checks run
before the node is made, so these tests need no DDS traffic; the parsing of the ROS arguments
(rcl's rules) is checked in-process.
"""

import subprocess
import sys
from pathlib import Path

import pytest

from abb_ros.nodes.ros.param_files import (
    ParamFileError,
    check_arguments,
    node_name_matches,
    parse_ros_arguments,
)
from abb_ros.nodes.ros.parameter_table import SPECS, specs_for

ROOT = Path(__file__).resolve().parents[3]
NODES = {'simulator': 'abb_simulator', 'analysis': 'abb_analysis', 'recorder': 'abb_recorder',
         'spin_controller': 'abb_spin_controller'}
KNOWN = {s.name for s in SPECS}

FILES = {
    'a misspelt drive key': ('/**:\n  ros__parameters:\n    drive:\n      kk: 4000.0\n',
                             "'drive.kk'"),
    'a misspelt node key': ('abb_simulator:\n  ros__parameters:\n    pubish_rate_hz: 500\n',
                            "'pubish_rate_hz'"),
    'a misspelt pacing key': ('/**:\n  ros__parameters:\n    real_time_facter: 0.0\n',
                              "'real_time_facter'"),
    'nested garbage': ('/**:\n  ros__parameters:\n    drive:\n      k:\n        x: {y: 1}\n',
                       "'drive.k.x.y'"),
    'garbage beside a section': ('/**:\n  ros__parameters:\n    drive: {k: 4000.0}\n'
                                 'junk: 3\n', "'junk'"),
    'a key given twice': ('/**:\n  ros__parameters:\n    drive: {k: 1.0}\n    drive: {c: 1.0}\n',
                          "'drive'"),
    'a key given twice by a dotted name': ('/**:\n  ros__parameters:\n    drive.k: 1.0\n'
                                           '    drive: {k: 2.0}\n', "'drive.k' is given twice"),
    'one line of text': ('hello, this is not a parameter file\n', 'the document is a str'),
    'an empty file': ('', 'the document is a NoneType'),
    'a list': ('- 1\n- 2\n', 'the document is a list'),
    'a misspelt node name': ('abb_simulater:\n  ros__parameters:\n    drive: {k: 4000.0}\n',
                             'no section applies'),
    'an empty section': ('/**:\n  ros__parameters: {}\n', 'holds no parameters'),
}


@pytest.mark.parametrize('case', sorted(FILES))
def test_a_file_each_node_would_ignore_is_refused_naming_file_and_key(tmp_path, case):
    """In-process: every node refuses each case, the message names the file and the key."""
    text, needle = FILES[case]
    path = tmp_path / 'params.yaml'
    path.write_text(text)
    for kind, name in NODES.items():
        if case in ('a misspelt node key', 'a misspelt node name') and kind != 'simulator':
            continue
        with pytest.raises(ParamFileError) as err:
            check_arguments(['x', '--ros-args', '--params-file', str(path)], name,
                            specs_for(kind), KNOWN)
        line = str(err.value)
        assert str(path) in line and needle in line and '\n' not in line


@pytest.mark.parametrize('kind, key', [('analysis', 'drive.kk'), ('recorder', 'topicz'),
                                       ('recorder', 'drive.k'), ('analysis', 'seed'),
                                       ('spin_controller', 'real_time_factor')])
def test_a_key_of_another_node_in_this_nodes_section_is_refused(tmp_path, kind, key):
    """A section naming the node holds only that node's parameters."""
    path = tmp_path / 'params.yaml'
    path.write_text(f'{NODES[kind]}:\n  ros__parameters:\n    {key}: 1.0\n')
    with pytest.raises(ParamFileError, match=f"unknown parameter '{key}'"):
        check_arguments(['--ros-args', '--params-file', str(path)], NODES[kind],
                        specs_for(kind), KNOWN)


def test_a_wildcard_section_may_serve_every_node_of_the_bench():
    """The shipped files (``/**``) hold the simulator's and the drive's parameters; every node
    takes them, as the launch file passes them to all."""
    files = [ROOT / 'config' / 'cdrom_table1.yaml', ROOT / 'config' / 'simulator.yaml']
    for kind, name in NODES.items():
        check_arguments(['--ros-args'] + [a for f in files for a in ('--params-file', str(f))],
                        name, specs_for(kind), KNOWN)


def test_sections_for_other_nodes_are_left_to_them(tmp_path):
    """A section for another node is not checked against this one; a namespaced name is."""
    path = tmp_path / 'params.yaml'
    path.write_text('abb_recorder:\n  ros__parameters:\n    topics: [a]\n'
                    'drive1:\n  abb_simulator:\n    ros__parameters:\n      seed: 3\n')
    args = ['--ros-args', '-r', '__ns:=/drive1', '--params-file', str(path)]
    check_arguments(args, 'abb_simulator', specs_for('simulator'), KNOWN)
    path.write_text('drive1:\n  abb_simulator:\n    ros__parameters:\n      sead: 3\n')
    with pytest.raises(ParamFileError, match="'sead'.*did you mean 'seed'"):
        check_arguments(args, 'abb_simulator', specs_for('simulator'), KNOWN)


def test_an_unknown_p_override_is_refused_and_one_for_another_node_is_not():
    own = specs_for('simulator')
    with pytest.raises(ParamFileError, match="-p drive.kk: unknown parameter 'drive.kk'"):
        check_arguments(['--ros-args', '-p', 'drive.kk:=1.0'], 'abb_simulator', own, KNOWN)
    check_arguments(['--ros-args', '-p', 'other:drive.kk:=1.0', '-p', 'use_sim_time:=true'],
                    'abb_simulator', own, KNOWN)
    with pytest.raises(ParamFileError):
        check_arguments(['--ros-args', '-r', '__node:=sim', '-p', 'sim:kk:=1.0'],
                        'abb_simulator', own, KNOWN)


def test_ros_arguments_are_read_as_rcl_reads_them():
    """Only inside --ros-args ... --; a flag's value is not a flag; targeted remaps apply to
    their node only; the first __node and __ns remap win."""
    ros = parse_ros_arguments(['prog', '--params-file', 'not_ros.yaml', '--ros-args',
                               '--log-level', '--params-file', '--params-file', 'a.yaml',
                               '-r', 'other:__node:=x', '-r', '__node:=sim', '-r',
                               '__node:=later', '-r', '__ns:=/ns1', '--', '--params-file',
                               'after.yaml', '--ros-args', '--params-file', 'b.yaml'])
    assert ros.files == ['a.yaml', 'b.yaml']
    assert ros.node_name('abb_simulator') == '/ns1/sim'
    assert ros.node_name('other') == '/ns1/x'


@pytest.mark.parametrize('pattern, fqn, match', [
    ('/**', '/abb_simulator', True), ('/**', '/a/b/abb_simulator', True),
    ('abb_simulator', '/abb_simulator', True), ('/abb_simulator', '/ns/abb_simulator', False),
    ('/**/abb_simulator', '/ns/abb_simulator', True), ('/*/abb_sim*', '/ns/abb_simulator', True),
    ('/*/abb_simulator', '/abb_simulator', False), ('ns/abb_simulator', '/ns/abb_simulator',
                                                    True)])
def test_node_names_match_as_in_rcl(pattern, fqn, match):
    assert node_name_matches(pattern, fqn) is match


@pytest.mark.parametrize('node', sorted(NODES))
@pytest.mark.parametrize('case', ['a misspelt drive key', 'one line of text',
                                  'a key given twice'])
def test_every_node_executable_exits_2_with_one_line(tmp_path, node, case):
    """The executables: exit code 2 within the time rclpy takes to start, one line."""
    text, needle = FILES[case]
    path = tmp_path / 'params.yaml'
    path.write_text(text)
    proc = subprocess.run([sys.executable, '-m', f'abb_ros.nodes.{node}', '--ros-args',
                           '--params-file', str(path)], cwd=ROOT, capture_output=True,
                          text=True, timeout=120, stdin=subprocess.DEVNULL)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and str(path) in lines[0] and needle in lines[0], proc.stderr
    assert 'Traceback' not in proc.stderr


def test_a_parameter_file_written_by_launch_ros_is_taken(tmp_path):
    """``ros2 launch`` (launch_ros) writes a node's parameters to a temporary file with
    ``yaml.dump``, a list parameter as ``!!python/tuple`` (bench.launch.py's
    ``record.topics``); rcl reads that as a list, so the check must too, not refuse it as
    malformed YAML (the simulator would exit 2 under every launch)."""
    import yaml

    from abb_ros.io.files.safe_yaml import load_file
    topics = ('stability/margin', '/diagnostics')
    path = tmp_path / 'launch_params_x'
    path.write_text(yaml.dump({'/abb_simulator': {'ros__parameters': {
        'real_time_factor': 1.0, 'record.start': False, 'record.path': '',
        'record.topics': topics}}}, default_flow_style=False))
    assert '!!python/tuple' in path.read_text()
    check_arguments(['x', '--ros-args', '-r', '__node:=abb_simulator', '--params-file',
                     str(path)], 'abb_simulator', specs_for('simulator'), KNOWN)
    loaded = load_file(path)['/abb_simulator']['ros__parameters']['record.topics']
    assert loaded == list(topics)


def test_no_other_python_tag_is_constructed(tmp_path):
    """Only the tuple tag is read: any other Python object stays refused."""
    from abb_ros.io.files.safe_yaml import YamlFileError, load_file
    path = tmp_path / 'evil.yaml'
    path.write_text("x: !!python/object/apply:os.system ['true']\n")
    with pytest.raises(YamlFileError, match='malformed YAML'):
        load_file(path)

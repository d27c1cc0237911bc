"""Numbers in every YAML file the package reads follow YAML 1.2 and ROS parameter files.

``5e-5`` and ``1E3`` are floats in a ROS 2 parameter file (rcl reads them with strtod) and in
YAML 1.2; PyYAML's YAML 1.1 reads them as text. Each format the package takes (the safe loader
itself, a drive parameter file, a scenario, a sweep spec, ``--set`` values) must read them as
the same float as the dotted spelling.
"""

import textwrap

import pytest

from abb_ros.io.files.drive_file import read_drive_yaml
from abb_ros.io.files.safe_yaml import _PyLoader, load_text
from abb_ros.io.files.scenario import load_scenario
from abb_ros.sweep.spec import load_spec

SPELLINGS = [('5e-5', 5e-5), ('1E3', 1000.0), ('-2e+3', -2000.0), ('.5e1', 5.0),
             ('1.e-3', 1e-3), ('+3E0', 3.0), ('4000e0', 4000.0)]


@pytest.mark.parametrize('loader', ['libyaml', 'pure python'])
@pytest.mark.parametrize('text, value', SPELLINGS)
def test_an_exponent_without_a_dot_is_a_float(monkeypatch, loader, text, value):
    """The safe loader reads YAML 1.2 floats as floats with and without libyaml."""
    if loader == 'pure python':
        from abb_ros.io.files import safe_yaml
        monkeypatch.setattr(safe_yaml, '_LOADER', safe_yaml._ros_loader(_PyLoader))
    got = load_text(f'x: {text}')['x']
    assert isinstance(got, float) and got == value


@pytest.mark.parametrize('text, value', [('5', 5), ('0x10', 16), ('1_000', 1000),
                                         ("'5e-5'", '5e-5'), ('1e', '1e'), ('e5', 'e5'),
                                         ('true', True), ('.inf', float('inf'))])
def test_integers_quoted_text_and_words_keep_their_types(text, value):
    """Only what the integer and 1.1 float rules leave as text becomes a float."""
    got = load_text(f'x: {text}')['x']
    assert got == value and type(got) is type(value)


def test_a_drive_file_takes_exponents_without_a_dot(tmp_path):
    """``drive.m: 43e-5`` in a parameter file is the ball mass 0.00043 kg, not text."""
    path = tmp_path / 'drive.yaml'
    path.write_text('/**:\n  ros__parameters:\n    drive:\n      m: 43e-5\n      k: 4E3\n')
    params = read_drive_yaml(path)
    assert params.m == pytest.approx(4.3e-4, rel=1e-15) and params.k == 4000.0


def test_a_scenario_takes_exponents_without_a_dot(tmp_path):
    """A scenario's initial deck state written as ``3e-4`` is 0.3 mm."""
    path = tmp_path / 's.yaml'
    path.write_text(textwrap.dedent("""\
        name: s
        description: d
        set: {wbar: 2.7}
        initial:
          deck: [3e-4, 3E-4, 0.0, 0.0, 0.0, 0.0]
          phi_deg: [60.0, -60.0]
        duration: 1e-1
        """))
    scenario = load_scenario(str(path))
    assert scenario.duration == pytest.approx(0.1, rel=1e-15)


def test_a_sweep_spec_takes_a_std_of_5e_5(tmp_path):
    """``std: 5e-5`` is the float 5e-5 (it was refused as the text '5e-5')."""
    path = tmp_path / 'spec.yaml'
    path.write_text(textwrap.dedent("""\
        name: t
        scenario: p3
        parameters:
          eps: {dist: normal, mean: 25e-5, std: 5e-5, low: 1e-4, high: 4e-4}
        samples: 4
        sampling: {method: sobol, seed: 3}
        partition_size: 2
        compute:
          run: {duration: 1e-1, rbar_limit: 1E-3}
        """))
    spec = load_spec(path)
    assert spec.parameters['eps']['std'] == 5e-5

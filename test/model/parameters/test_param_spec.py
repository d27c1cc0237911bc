"""The parameter specs: one check, the --set names of abb-sim, and what must agree with them.

The shipped YAML files, the module defaults and docs/parameters.md agree with the specs.
"""

import math
from pathlib import Path

import pytest
import yaml

from abb_ros.cli import main
from abb_ros.commands import settings
from abb_ros.model.parameters.drive_spec import DRIVE_SPECS
from abb_ros.model.parameters.param_spec import ParamError
from abb_ros.model.parameters.params import DriveParams
from abb_ros.nodes.ros import parameter_table
from abb_ros.nodes.ros.parameter_table import SPECS, specs_for

ROOT = Path(__file__).resolve().parents[3]


def _flatten(mapping, prefix=''):
    out = {}
    for key, value in mapping.items():
        if isinstance(value, dict):
            out.update(_flatten(value, f'{prefix}{key}.'))
        else:
            out[prefix + key] = value
    return out


def _shipped(name):
    doc = yaml.safe_load((ROOT / 'config' / name).read_text())
    return _flatten(doc['/**']['ros__parameters'])


def test_shipped_yaml_files_name_every_simulator_parameter_with_the_spec_default():
    shipped = {**_shipped('cdrom_table1.yaml'), **_shipped('simulator.yaml')}
    specs = specs_for('simulator')
    computed = {name for name, s in specs.items() if s.default is None}
    assert set(shipped) == set(specs) - computed
    for name, value in shipped.items():
        default = specs[name].default
        assert type(value) is type(default) and value == default, name
        assert specs[name].check(value) == default


def test_docs_parameter_table_is_generated_from_the_spec():
    committed = (ROOT / 'docs' / 'parameters.md').read_text()
    assert committed == parameter_table.markdown(settings.commands_taking), \
        'regenerate: python scripts/make_parameters_doc.py > docs/parameters.md'
    for spec in SPECS:
        assert f'| `{spec.name}` |' in committed and spec.valid_text() in committed


def test_module_defaults_are_the_spec_defaults():
    from abb_ros.io.bag.writer import DEFAULT_CHUNK_SIZE
    from abb_ros.model.dynamics.integrate import DEFAULT_DT
    from abb_ros.model.stability.speed_bands import TABLE_POINTS
    assert DriveParams().as_dict() == {s.short: s.default for s in DRIVE_SPECS}
    assert DEFAULT_DT == 1.0 / specs_for('simulator')['integration_rate_hz'].default
    assert TABLE_POINTS == specs_for('analysis')['table_points'].default
    assert DEFAULT_CHUNK_SIZE == specs_for('recorder')['chunk_size'].default
    from abb_ros.nodes.spin_controller.run_up import GUARD_WBAR
    assert GUARD_WBAR == specs_for('spin_controller')['guard_wbar'].default
    assert TABLE_POINTS == specs_for('spin_controller')['table_points'].default


def test_recorder_default_topics_are_the_recorded_topics_of_the_topic_list():
    from abb_ros.io.wire import topics
    assert specs_for('recorder')['topics'].default == [t.name for t in topics.recorded_topics()]


def test_every_spec_default_passes_its_own_check():
    for spec in SPECS:
        if spec.default is not None:
            assert spec.check(spec.default, strict=True) == spec.default, spec.name


def test_integer_literal_for_a_double_is_accepted_as_the_double():
    k = specs_for('simulator')['drive.k']
    value = k.check(4000, strict=True)
    assert value == 4000.0 and type(value) is float


@pytest.mark.parametrize('name,value,why', [
    ('drive.k', 'abc', 'not a number'), ('drive.k', [1.0], 'not a number'),
    ('drive.k', True, 'not a number'), ('drive.n', 2.0, 'not an integer'),
    ('seed', 1.5, 'not an integer'), ('imu.gravity', 1, 'not true or false'),
    ('imu.position', [0.0, 1.0], ''), ('drive.k', 0.0, ''), ('drive.c', math.nan, 'finite')])
def test_wrong_types_and_values_give_one_line_naming_the_parameter_and_the_range(
        name, value, why):
    spec = specs_for('simulator')[name]
    with pytest.raises(ParamError) as err:
        spec.check(value, strict=True)
    text = str(err.value)
    assert '\n' not in text and f"'{name}'" in text
    assert f'valid range is {spec.valid_text()}' in text and why in text


def test_open_and_closed_bounds_read_as_intervals():
    specs = specs_for('simulator')
    assert specs['drive.k'].valid_text() == '[0.003972, 3.972e+09] N/m'
    assert specs['drive.c'].valid_text() == '[0, 2.53e+06] kg/s'
    assert specs['spindle.max_accel'].valid_text() == '(0, 1e+09] rad/s^2'
    assert specs['fault.imu_accel_bias_step'].valid_text() == '3 values in [-1000, 1000] [m/s^2]'
    assert specs['drive.n'].valid_text() == '[0, 64]'
    assert specs['drive.c'].check(0.0) == 0.0
    with pytest.raises(ParamError):
        specs['drive.k'].check(0.0)


def test_cli_set_names_come_from_the_spec():
    assert {'k', 'n', 'imu.accel_noise_density', 'seed', 'spindle.tau'} <= set(
        settings.cli_names('run'))
    assert 'imu.accel_noise_density' not in settings.cli_names('stability')
    assert 'real_time_factor' not in settings.cli_names('run')


def test_stability_refuses_a_node_parameter_naming_the_valid_ones(capsys):
    assert main(['stability', '--set', 'wbar=2', '--set', 'imu.gyro_bias=0']) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert "'imu.gyro_bias'" in err and 'unknown parameter' in err and 'wbar' in err


@pytest.mark.parametrize('setting,needle', [
    ('imu.accel_noise_density=-1', "'imu.accel_noise_density'"),
    ('seed=x', "'seed'"), ('publish_rate_hz=7', 'divisor of integration_rate_hz'),
    ('imu.position=[0, 1]', "'imu.position'")])
def test_run_refuses_bad_node_parameters_with_exit_code_2(capsys, setting, needle):
    assert main(['run', '--duration', '0.01', '--no-progress', '--set', setting]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and needle in err


def _imu_samples(capsys, tmp_path, name, *settings):
    from abb_ros.io.bag.reader import read_bag
    out = tmp_path / name
    argv = ['run', '--scenario', 'p3', '--duration', '0.05', '--no-progress', '--out', str(out)]
    for s in settings:
        argv += ['--set', s]
    code = main(argv)
    assert code == 0, capsys.readouterr().err
    capsys.readouterr()
    return [(m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z,
             m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z)
            for topic, m, _ in read_bag(out) if topic == '/deck/imu']


@pytest.mark.slow
def test_run_set_imu_noise_zero_gives_a_noiseless_imu_in_the_bag(capsys, tmp_path):
    silent = [f'imu.{k}=0' for k in ('accel_noise_density', 'accel_bias',
                                     'accel_bias_random_walk', 'gyro_noise_density',
                                     'gyro_bias', 'gyro_bias_random_walk')]
    quiet_1 = _imu_samples(capsys, tmp_path, 'q1', 'seed=1', *silent)
    quiet_2 = _imu_samples(capsys, tmp_path, 'q2', 'seed=2', *silent)
    noisy_1 = _imu_samples(capsys, tmp_path, 'n1', 'seed=1')
    noisy_2 = _imu_samples(capsys, tmp_path, 'n2', 'seed=2')
    assert len(quiet_1) == 51
    assert quiet_1 == quiet_2          # no noise: the seed does not matter
    assert noisy_1 != noisy_2          # the seed reaches the IMU model
    assert noisy_1 != quiet_1


def test_run_set_imu_rate_and_spindle_motor_apply_headless(capsys, tmp_path):
    import json
    samples = _imu_samples(capsys, tmp_path, 'r', 'imu.rate_hz=500')
    assert len(samples) == 26          # t = 0 and every 2 ms for 50 ms
    assert main(['run', '--scenario', 'p3', '--duration', '0.05', '--no-progress', '--json',
                 '--set', 'spindle.initial_speed=100', '--set', 'spindle.tau=0.01']) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary['omega_rad_s'] == pytest.approx(100.0)


def test_the_step_in_seconds_is_one_over_every_valid_rate():
    """The nodes and ``abb-sim run`` take the step from plant_spec.step_of, whose seconds equal
    1 / rate for every divisor of 1e9 the spec accepts: live and headless runs integrate with
    the same float step (``dt_ns * 1e-9`` differs at 18 of them, e.g. 15625 Hz)."""
    from abb_ros.model.parameters.plant_spec import PLANT, step_of
    spec = PLANT['integration_rate_hz']
    rates = [r for r in range(spec.low, spec.high + 1) if 1_000_000_000 % r == 0]
    assert len(rates) > 50
    for rate in rates:
        dt_ns, dt = step_of(rate)
        assert dt_ns * rate == 1_000_000_000 and dt == 1.0 / rate, rate

"""Parameters: Table 1, Eq. (39) conversions both ways, validation and the ROS 2 YAML file."""

import math

import pytest

from abb_ros.io.files.drive_file import read_drive_yaml, write_drive_yaml
from abb_ros.model.parameters.params import METAL_C, DriveParams, ParamError, apply_settings

TABLE1 = DriveParams()


def test_table1_dimensionless_values_match_section4():
    # omega0 = sqrt(4k/(M+M_P)) = 300.45 rad/s (the paper: ~298, see test_linear for the gap);
    # zeta of metal washers 0.025 and rubber ~0.1 (Section 4 quotes 0.025 and 0.1).
    assert TABLE1.omega0 == pytest.approx(math.sqrt(4 * 3972 / 0.176), rel=1e-12)
    assert TABLE1.replace(c=METAL_C).zeta == pytest.approx(0.025, abs=5e-4)
    assert TABLE1.zeta == pytest.approx(0.0957, abs=5e-4)
    assert TABLE1.epsbar == pytest.approx(0.25 / 15)
    assert TABLE1.mbar == pytest.approx(0.43 / 26)


@pytest.mark.parametrize('name,value', [('wbar', 2.7), ('zeta', 0.025), ('Dbar', 0.3),
                                        ('epsbar', 0.04), ('mbar', 0.03)])
def test_dimensionless_settings_round_trip(name, value):
    params, omega = apply_settings(TABLE1, {name: value})
    got = params.wbar(omega) if name == 'wbar' else getattr(params, name)
    assert got == pytest.approx(value, rel=1e-12)


def test_mbar_keeps_si_drag_and_dbar_uses_final_mass():
    params, _ = apply_settings(TABLE1, {'Dbar': 0.2, 'mbar': 0.03})
    assert params.m == pytest.approx(0.03 * TABLE1.M)
    assert params.Dbar == pytest.approx(0.2)
    params, _ = apply_settings(TABLE1, {'mbar': 0.03})
    assert params.D == TABLE1.D


@pytest.mark.parametrize('name,value,fragment', [
    ('M', 0.0, "'M'"), ('k', -1.0, '[0.003972, 3.972e+09] N/m'), ('c', -0.1, '[0, 2.53e+06] kg/s'),
    ('n', -1, "'n'"), ('n', 2.5, 'integer'), ('R', math.nan, 'not finite'),
    ('J_z', math.inf, 'not finite'), ('eps', -1e-3, "'eps'")])
def test_invalid_values_name_the_parameter_and_range(name, value, fragment):
    with pytest.raises(ParamError) as err:
        TABLE1.replace(**{name: value})
    assert err.value.name == name
    assert fragment in str(err.value)
    assert 'valid range' in str(err.value)


def test_unknown_and_bad_dimensionless_settings_are_refused():
    with pytest.raises(ParamError, match="'wbarr'.*unknown"):
        apply_settings(TABLE1, {'wbarr': 1.0})
    with pytest.raises(ParamError, match="'mbar'"):
        apply_settings(TABLE1, {'mbar': -0.1})
    with pytest.raises(ParamError, match="'zeta'"):
        apply_settings(TABLE1, {'zeta': math.nan})


def test_yaml_round_trip_and_table1_file(tmp_path):
    from pathlib import Path
    shipped = Path(__file__).resolve().parents[3] / 'config' / 'cdrom_table1.yaml'
    assert read_drive_yaml(shipped) == TABLE1
    custom = TABLE1.replace(c=METAL_C, n=10, m=1.5e-4)
    path = tmp_path / 'drive.yaml'
    write_drive_yaml(custom, path)
    assert read_drive_yaml(path) == custom


def test_yaml_with_bad_value_is_refused(tmp_path):
    path = tmp_path / 'bad.yaml'
    path.write_text('/**:\n  ros__parameters:\n    drive:\n      k: -5.0\n')
    with pytest.raises(ParamError, match="'k'"):
        read_drive_yaml(path)

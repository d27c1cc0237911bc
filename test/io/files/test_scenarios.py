"""The shipped scenarios are the paper's points (Section 5) with its initial conditions."""

import numpy as np
import pytest

from abb_ros.io.files.scenario import list_scenarios, load_scenario
from abb_ros.model.parameters.params import METAL_C, RUBBER_C, ParamError

POINTS = {  # Section 5: (mbar, wbar, washer damping c)
    'p1': (0.03, 0.8, METAL_C), 'p2': (0.03, 2.18, METAL_C), 'p3': (0.03, 2.7, METAL_C),
}


def test_every_shipped_scenario_loads():
    names = list_scenarios()
    assert {'p1', 'p2', 'p3', 'p4', 'p3_n10', 'p3_n10_scattered', 'spinup_p1_p3'} <= set(names)
    for name in names:
        scenario = load_scenario(name)
        assert scenario.duration > 0 and scenario.omega > 0


@pytest.mark.parametrize('name', sorted(POINTS))
def test_p1_to_p3_are_fig7b_points_with_metal_washers(name):
    mbar, wbar, c = POINTS[name]
    s = load_scenario(name)
    assert s.params.mbar == pytest.approx(mbar)
    assert s.omega / s.params.omega0 == pytest.approx(wbar)
    assert s.params.c == c and s.params.zeta == pytest.approx(0.025, abs=5e-4)
    assert s.deck0 == (0.3e-3, 0.3e-3, 0.3e-3, 0.0, 0.0, 0.0)


def test_p4_is_fig6_point_beyond_capacity_with_rubber_washers():
    s = load_scenario('p4')
    assert s.params.epsbar == pytest.approx(0.04)
    assert s.omega / s.params.omega0 == pytest.approx(1.5)
    assert s.params.c == RUBBER_C and not s.params.can_balance


def test_ten_ball_scenarios_keep_the_two_ball_mass_and_time_constant():
    two = load_scenario('p3').params
    for name in ('p3_n10', 'p3_n10_scattered'):
        ten = load_scenario(name).params
        assert ten.n == 10 and ten.n * ten.m == pytest.approx(two.n * two.m)
        assert ten.m * ten.R ** 2 / ten.D == pytest.approx(two.m * two.R ** 2 / two.D)
    scattered = load_scenario('p3_n10_scattered').phi0
    assert np.ptp(np.degrees(scattered)) > 300          # spread around the whole race


def test_settings_on_top_of_a_scenario_and_ball_count_change():
    s = load_scenario('p3').with_settings({'wbar': 2.0, 'n': 4})
    assert s.omega / s.params.omega0 == pytest.approx(2.0)
    assert s.params.n == 4 and s.phi0 is None            # explicit +-60 deg dropped for n = 4


TWO_RACES = """name: two_races
description: P3 with G 1 mm up and a second race mirrored about it
set: {mbar: 0.03, c: 0.66, wbar: 2.7, z_G: 0.001, race2.n: 2, race2.z: 0.002}
initial:
  phi_deg: [60.0, -60.0, 150.0, -150.0]
duration: 1.0
"""


def test_a_scenario_sets_a_second_race_and_lists_race_1s_angles_then_race_2s(tmp_path):
    path = tmp_path / 'two_races.yaml'
    path.write_text(TWO_RACES)
    s = load_scenario(str(path))
    assert (s.params.n, s.params.race2_n, s.params.race2_z) == (2, 2, 0.002)
    assert np.degrees(s.phi0) == pytest.approx([60.0, -60.0, 150.0, -150.0])
    path.write_text(TWO_RACES.replace(', 150.0, -150.0', ''))
    with pytest.raises(ParamError, match="initial.phi_deg.*race 1's n = 2 then race 2's "
                                         'race2.n = 2'):
        load_scenario(str(path))

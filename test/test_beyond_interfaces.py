"""Issue 12: the beyond-the-paper parameters flow through every interface (CLI run, stability,
scenarios, ROS parameter descriptors of the simulator and analysis nodes)."""

import json

import numpy as np
import pytest

from abb_ros.cli import main
from abb_ros.io.scenario import load_scenario
from abb_ros.model.params import PARAM_SPECS, DriveParams
from abb_ros.nodes import ros_params

STEEL_P1 = ['--set', 'r_ball=2.873e-3', '--set', 'contact_E=2e11', '--set', 'rolling_mu=1e-6',
            '--set', 'ball_rotation=1']


def test_headless_run_takes_the_new_parameters_and_reports_refined_steps(abb_sim):
    """abb-sim run --set r_ball=... on P1: the balls meet within 0.3 s (docs/beyond_the_paper.md,
    P1 figure), so contact sub-steps are reported in the summary, with the active terms; the
    rolling balls stick and slip, so located rolling switches are reported too."""
    code, out, err = abb_sim('run', '--scenario', 'p1', '--duration', '0.5', '--json',
                             '--no-progress', *STEEL_P1)
    assert code == 0, err
    summary = json.loads(out)
    assert summary['beyond_paper'] == ['contact', 'rolling_mu', 'ball_rotation']
    assert summary['contact_refined_steps'] > 0 and summary['contact_max_substeps'] > 1
    assert summary['rolling_switches'] > 0


def test_stability_says_which_terms_the_linear_analysis_ignores(capsys):
    code = main(['stability', '--set', 'mbar=0.03', '--set', 'wbar=2.7', '--json', *STEEL_P1])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    assert 'contact, rolling_mu, ball_rotation' in out['note']
    assert out['verdict'] == 'balanced'


def test_stability_of_the_paper_model_has_no_note(capsys):
    main(['stability', '--set', 'mbar=0.03', '--set', 'wbar=2.7', '--json'])
    assert 'note' not in json.loads(capsys.readouterr().out)


def test_bad_beyond_paper_value_exits_2_naming_it(abb_sim):
    code, _, err = abb_sim('run', '--scenario', 'p3', '--set', 'rolling_mu=1e-6')
    assert code == 2
    assert "'r_ball'" in err and 'rolling_mu' in err and len(err.strip().splitlines()) == 1


def test_scenario_settings_take_the_new_parameters():
    scenario = load_scenario('p3').with_settings({'r_ball': 2e-3, 'contact_E': 2e11})
    assert scenario.params.beyond_paper == ('contact',)


@pytest.mark.parametrize('name', ['r_ball', 'contact_E', 'contact_nu', 'contact_damping',
                                  'rolling_mu', 'rolling_stick_rate', 'ball_rotation'])
def test_node_parameter_descriptor_matches_the_default_type(name):
    """drive.<name> is declared by the simulator and analysis nodes from DriveParams: an integer
    parameter (ball_rotation) gets an integer range, the others a floating-point range."""
    assert name in PARAM_SPECS
    d = ros_params.descriptor(PARAM_SPECS[name])
    default = getattr(DriveParams(), name)
    if isinstance(default, int):
        assert d.integer_range and not d.floating_point_range
    else:
        assert d.floating_point_range and not d.integer_range


def test_overlapping_start_with_contact_exits_2_naming_phi0(abb_sim):
    """p3_n10 starts its ten balls 1 deg apart: with 1.68 mm balls in contact that is an
    overlap, refused with one line naming phi0 and the least separation."""
    code, _, err = abb_sim('run', '--scenario', 'p3_n10', '--set', 'r_ball=1.68e-3',
                           '--set', 'contact_E=2e11', '--duration', '0.1', '--no-progress')
    assert code == 2
    assert "'phi0'" in err and '12.8' in err and len(err.strip().splitlines()) == 1


def test_with_contact_the_default_start_puts_the_balls_side_by_side_just_apart():
    """No start angles given (the simulator node, a scenario without phi_deg): with contact the
    two groups of Section 5's start are spread by the contact separation + 0.1 deg instead of
    1 deg, so ten steel balls start without overlap; without contact the start is the paper's."""
    from abb_ros.model.ball_materials import with_steel_balls
    from abb_ros.model.integrate import default_phi0, initial_state
    paper = DriveParams(n=10)
    steel = with_steel_balls(paper)
    phi = np.degrees(initial_state(steel, 500.0)[7:17])
    gaps = np.diff(np.sort(phi))
    assert gaps.min() == pytest.approx(np.degrees(steel.contact_separation) + 0.1)
    assert phi[:2] == pytest.approx([60.0, -60.0])
    assert np.array_equal(initial_state(paper, 500.0)[7:17], default_phi0(10))
    assert np.degrees(default_phi0(4)).round(12).tolist() == [60.0, -60.0, 61.0, -61.0]

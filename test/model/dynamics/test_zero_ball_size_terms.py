"""With every ball-size, contact and rolling parameter at zero the model is the paper's.

The reference (test/data/paper_reference.npz) holds the states every 100 ms of P1-P4 and P3 with
ten balls, computed by the code before the new terms existed (test/paper_reference.py).
"""

import dataclasses

import numpy as np
import paper_reference
import pytest

from abb_ros.app.headless import run_scenario
from abb_ros.io.files.scenario import load_scenario

ZEROS = dict(r_ball=0.0, contact_E=0.0, contact_nu=0.0, contact_damping=0.0, rolling_mu=0.0,
             ball_rotation=0)
"""Every ball-size, contact and rolling parameter at zero (rolling_stick_rate must stay > 0; it
only acts with rolling_mu > 0)."""


@pytest.fixture(scope='module')
def reference():
    """Return the paper-model reference states (test/data/paper_reference.npz)."""
    with np.load(paper_reference.PATH) as data:
        return {name: data[name] for name in data.files}


def _states(name, duration=None, **settings):
    scenario = load_scenario(name).with_settings(settings)
    if duration is not None:
        scenario = dataclasses.replace(scenario, duration=duration)
    return run_scenario(scenario).y[::paper_reference.STRIDE]


def test_default_parameters_have_no_beyond_paper_terms():
    """P3's drive, and P3 with every ball-size, contact and rolling parameter at zero, has no term
    beyond the paper."""
    scenario = load_scenario('p3')
    assert scenario.params.beyond_paper == ()
    assert scenario.with_settings(ZEROS).params.beyond_paper == ()


def test_zero_parameters_reproduce_the_first_second_of_p3_bit_for_bit(reference):
    """With the ball-size, contact and rolling parameters at zero, the first second of P3 equals
    the paper model's bit for bit."""
    y = _states('p3', duration=1.0, **ZEROS)
    np.testing.assert_array_equal(y, reference['p3'][:len(y)])


@pytest.mark.slow
@pytest.mark.parametrize('name', paper_reference.SCENARIOS)
def test_zero_parameters_reproduce_the_paper_runs_bit_for_bit(name, reference):
    """P1-P4 and P3 with ten balls, whole runs: every stored state identical."""
    y = _states(name, **ZEROS)
    assert y.shape == reference[name].shape
    np.testing.assert_array_equal(y, reference[name])

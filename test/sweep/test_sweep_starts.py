"""Sweeps over starts: initial ball angles and deck displacement as drawn parameters.

The runs start where the draws say (checked against abb-sim run's integration from that
start), the spec refuses incomplete or misplaced starts in one line, and the report gives the
probability of balancing per bin with its Wilson interval.
"""

import dataclasses
import json

import numpy as np
import pytest

from abb_ros.app.headless import run_scenario
from abb_ros.model.parameters.params import ParamError
from abb_ros.sweep.compute import compute_partition
from abb_ros.sweep.proportions import wilson
from abb_ros.sweep.report import make_report
from abb_ros.sweep.runner import run_sweep
from abb_ros.sweep.sampling import draw_samples
from abb_ros.sweep.spec import parse_spec


def _doc(**parameters):
    return {'scenario': 'p3', 'samples': 6, 'sampling': {'method': 'random', 'seed': 3},
            'parameters': parameters or {
                'phi1_deg': {'dist': 'uniform', 'low': -180, 'high': 180},
                'phi2_deg': {'dist': 'uniform', 'low': -180, 'high': 180},
                'X0': {'dist': 'uniform', 'low': -1e-3, 'high': 1e-3}},
            'compute': {'run': {'duration': 0.2, 'rbar_limit': 1e-2}}}


STEEL_ROLLING = {'r_ball': 2.3559716663050265e-3, 'contact_E': 2e11, 'rolling_mu': 1e-6}


@pytest.mark.parametrize('base', [{}, STEEL_ROLLING], ids=['paper', 'steel_rolling'])
def test_runs_start_at_the_drawn_ball_angles_and_deck_displacement(base):
    """A drawn start runs as abb-sim run's integration from that start does, to the bit.

    Also with steel balls in contact and rolling resistance: a sweep over friction and
    starts integrates what abb-sim run does.
    """
    doc = _doc()
    doc['base'] = base
    spec = parse_spec(doc)
    samples = draw_samples(spec)
    result = compute_partition(dataclasses.replace(spec, partition_size=6), 0, samples)
    for i in (0, 4):
        scen = dataclasses.replace(
            spec.scenario, duration=0.2,
            phi0=np.radians([samples['phi1_deg'][i], samples['phi2_deg'][i]]),
            deck0=(samples['X0'][i],) + tuple(spec.scenario.deck0[1:]))
        y = run_scenario(scen).y[-1]
        rbar = np.sqrt(y[1] ** 2 + y[2] ** 2 + y[3] ** 2) / scen.params.R
        assert result['final_rbar'][i] == rbar
    assert np.ptp(result['final_rbar']) > 0      # the starts differ, and so do the runs


@pytest.mark.parametrize('parameters,field', [
    ({'phi2_deg': {'dist': 'uniform', 'low': 0, 'high': 90}}, 'parameters'),
    ({'phi1_deg': {'dist': 'uniform', 'low': 0, 'high': 90}}, 'parameters.phi2_deg'),
    ({'phi1_deg': {'dist': 'uniform', 'low': 0, 'high': 400}}, 'parameters.phi1_deg.high'),
    ({'Z0': {'dist': 'uniform', 'low': 0, 'high': 0.1}}, 'parameters.Z0.high'),
])
def test_incomplete_or_out_of_range_starts_are_refused(parameters, field):
    """Ball angles phi1..phiK for every ball, within their ranges; the error names the field."""
    with pytest.raises(ParamError) as err:
        parse_spec(_doc(**parameters))
    assert err.value.name == field
    assert '\n' not in str(err.value)


def test_starts_need_a_run_and_are_not_drive_settings():
    """Starts without compute.run, or in base, are refused naming the field."""
    doc = _doc()
    doc['compute'] = {'stability': {'wbar': [2.7]}}
    with pytest.raises(ParamError, match='compute.run'):
        parse_spec(doc)
    doc = _doc()
    doc['base'] = {'phi1_deg': 10.0}
    with pytest.raises(ParamError) as err:
        parse_spec(doc)
    assert err.value.name == 'base.phi1_deg'


@pytest.mark.slow
def test_report_gives_the_probability_of_balancing_per_bin_with_its_interval(tmp_path):
    """balanced_by_bin: per bin the balanced count of the rows and its Wilson interval."""
    doc = _doc()
    doc['samples'] = 24
    doc['compute']['run']['duration'] = 0.5
    spec = parse_spec(doc)
    run_sweep(spec, tmp_path / 'sweep')
    summary = make_report(tmp_path / 'sweep', tmp_path / 'fig')
    bins = summary['balanced_by_bin']['phi1_deg']
    assert sum(b['runs'] for b in bins) == 24
    assert sum(b['balanced'] for b in bins) == round(summary['yield'] * 24)
    for b in bins:
        assert b['ci95'] == list(wilson(b['balanced'], b['runs']))
    assert (tmp_path / 'fig' / 'balanced_vs_phi1_deg.png').exists()
    json.dumps(summary)

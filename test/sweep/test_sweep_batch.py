"""Batched nonlinear runs (abb_ros/model/dynamics/batch.py) and partitions computed in-process."""

import dataclasses

import numpy as np
import pytest

from abb_ros.model.dynamics import batch, kernels
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.spindle import ConstantSpeed, SpindleMotor
from abb_ros.model.dynamics.state import wrap_degrees
from abb_ros.model.parameters.params import DriveParams, apply_settings
from abb_ros.sweep.compute import compute_partition
from abb_ros.sweep.sampling import draw_samples
from abb_ros.sweep.spec import parse_spec

P3, OMEGA = apply_settings(DriveParams(), {'mbar': 0.03, 'c': 0.66, 'wbar': 2.7})
DT = 1e-4


def _batch(plist, omega=OMEGA, spindle=ConstantSpeed(), kern=None, limit=1e-3):
    y0 = np.array([initial_state(p, omega) for p in plist])
    S = np.array([spindle.pack(omega)] * len(plist))
    return batch.BatchRun(plist, y0, S, DT, limit, kern=kern)


def test_each_sample_of_a_batch_follows_its_single_run_trajectory_bit_for_bit():
    plist = [P3.replace(k=3972.0 * (1 + 0.04 * i), c=0.5 + 0.1 * i) for i in range(5)]
    br = _batch(plist, spindle=SpindleMotor(2000.0, 0.05))
    br.set_omega_cmd(1.1 * OMEGA)
    br.advance(1500)
    for i, p in enumerate(plist):
        y = initial_state(p, OMEGA)
        S = SpindleMotor(2000.0, 0.05).pack(1.1 * OMEGA)
        done, status = kernels.JIT.advance(y, 0.0, DT, 0, 1500, kernels.pack_params(p), S,
                                           kernels.make_work(p.n))
        assert status == kernels.OK and done == 1500
        assert np.array_equal(y, br.Y[i])


def test_in_kernel_metrics_equal_the_metrics_of_the_sampled_trajectory():
    plist = [P3, P3.replace(eps=0.4e-3), P3.replace(c=0.3)]
    br = _batch(plist, limit=5e-3)
    for _ in range(4):                      # in segments: the metrics carry over
        br.advance(500)
    for i, p in enumerate(plist):
        y = initial_state(p, OMEGA)
        out = np.empty((2000, y.size))
        kernels.JIT.trajectory(y, 0.0, DT, 0, 2000, 1, kernels.pack_params(p),
                               ConstantSpeed().pack(OMEGA), kernels.make_work(p.n), out)
        rbar = np.sqrt((out[:, 1:4] ** 2).sum(axis=1)) / p.R
        t_end = (np.arange(2000) + 1) * DT
        assert br.metrics[i, batch.PEAK_RBAR] == rbar.max()
        assert br.metrics[i, batch.TIME_ABOVE] == pytest.approx((rbar > 5e-3).sum() * DT,
                                                                rel=1e-12)
        above = np.flatnonzero(rbar > 5e-3)
        expect = t_end[above[-1]] if rbar[-1] <= 5e-3 else np.nan
        assert np.array_equal(br.settle_time[i], expect, equal_nan=True)


def test_the_python_twin_of_the_batch_kernel_agrees_with_the_compiled_one():
    plist = [P3, P3.replace(k=4300.0)]
    a = _batch(plist)
    b = _batch(plist, kern=batch.PY)
    a.advance(20)
    b.advance(20)
    np.testing.assert_allclose(a.Y, b.Y, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(a.metrics, b.metrics, rtol=1e-12)


def test_a_run_that_blows_up_keeps_its_last_good_state_and_the_others_go_on():
    # k = 1e9 N/m: valid, but its mode (1.5e5 rad/s) is far beyond what a 10 kHz RK4 resolves
    plist = [P3, P3.replace(k=1e9), P3.replace(k=4200.0)]
    br = _batch(plist)
    br.advance(300)
    assert list(br.status) == [kernels.OK, br.status[1], kernels.OK]
    assert br.status[1] in (kernels.NONFINITE, kernels.ENVELOPE)
    assert np.all(np.isfinite(br.Y[1])) and 0 <= br.metrics[1, batch.FAIL_TIME] < 300 * DT
    assert np.isnan(br.settle_time[1])
    good = _batch([P3, P3.replace(k=4200.0)])
    good.advance(300)
    assert np.array_equal(good.Y, br.Y[[0, 2]])


def test_a_blown_up_sample_is_recorded_as_failed_with_its_cause_and_the_sweep_goes_on():
    doc = {'parameters': {'k': {'dist': 'grid', 'values': [3972.0, 1e9]}},
           'compute': {'run': {'duration': 0.02}}}
    spec = parse_spec(doc)
    res = compute_partition(spec, 0, draw_samples(spec))
    assert list(res['failed']) == [False, True]
    assert list(res['status']) == ['ok', res['status'][1]] and res['status'][1] in (
        'nonfinite', 'envelope')
    assert res['cause'][0] == '' and 'integration stopped' in res['cause'][1]
    assert np.isfinite(res['final_rbar']).all() and not res['run_balanced'][1]


def test_a_partition_does_not_depend_on_how_the_samples_are_partitioned():
    doc = {'parameters': {'eps': {'dist': 'uniform', 'low': 0.1e-3, 'high': 0.5e-3},
                          'n': {'dist': 'list', 'values': [2, 3]},
                          'c': {'dist': 'normal', 'mean': 0.66, 'std': 0.1, 'low': 0.3,
                                'high': 1.0}},
           'samples': 9, 'sampling': {'method': 'lhs', 'seed': 5}, 'partition_size': 4,
           'compute': {'stability': {'wbar': [2.0, 2.7]}, 'run': {'duration': 0.02}}}
    spec = parse_spec(doc)
    samples = draw_samples(spec)
    whole = compute_partition(dataclasses.replace(spec, partition_size=9), 0, samples)
    parts = [compute_partition(spec, i, {k: v[slice(*spec.partition_bounds(i))]
                                         for k, v in samples.items()})
             for i in range(spec.partitions)]
    for name, values in whole.items():
        if name == 'partition':
            continue
        joined = [v for part in parts for v in part[name]]
        if name == 'phi_final_deg':
            assert all(np.array_equal(a, b) for a, b in zip(values, joined))
        else:
            assert np.array_equal(np.asarray(values), np.asarray(joined),
                                  equal_nan=values.dtype.kind == 'f'), name
    assert {len(v) for v in whole['phi_final_deg']} == {2, 3}


def test_a_run_up_scenario_commands_the_motor_at_the_first_step_at_or_after_its_time(tmp_path):
    from abb_ros.model.dynamics.integrate import Simulation
    path = tmp_path / 'runup.yaml'
    path.write_text('name: runup\nset: {mbar: 0.03, c: 0.66, wbar: 0.8}\nduration: 5.0\n'
                    'spindle: {model: motor, max_accel: 2000.0, tau: 0.05, '
                    'commands: [{t: 0.01, wbar: 2.7}]}\n')
    spec = parse_spec({'scenario': str(path), 'samples': 2,
                       'parameters': {'k': {'dist': 'list', 'values': [3972.0, 4100.0]}},
                       'compute': {'run': {'duration': 0.03}}})
    samples = draw_samples(spec)
    res = compute_partition(spec, 0, samples)
    nominal = spec.scenario.params
    omega_start, omega_cmd = 0.8 * nominal.omega0, 2.7 * nominal.omega0
    assert spec.operating_omega == omega_cmd
    for i, k in enumerate(samples['k']):
        p = nominal.replace(k=float(k))
        sim = Simulation(p, omega_start, DT, spindle=SpindleMotor(2000.0, 0.05))
        sim.advance(100)
        sim.set_speed_command(omega_cmd)
        sim.advance(200)
        assert res['omega_final'][i] == sim.omega > omega_start + 2000.0 * 0.019
        assert res['final_rbar'][i] == pytest.approx(sim.rbar, rel=1e-14)
        assert np.array_equal(res['phi_final_deg'][i],
                              wrap_degrees(sim.phi))

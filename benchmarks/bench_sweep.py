"""Throughput of `abb-sim sweep`'s compute: samples per second, printed (not asserted).

For Floquet points (in- and out-of-plane |lambda|max at P3's speed) and for 1 s nonlinear runs
(P3, metrics peak rbar, time above the limit and settle time):

(a) one sample per kernel call in a Python loop (runs: ``kernels.stepper.trajectory`` storing
    every step, metrics from the stored trajectory with numpy);
(b) batched in-process: one kernel call for the whole batch (``max_multiplier_batch``,
    ``batch.BatchRun`` with the metrics inside the kernel);
(c) ``run_sweep`` on a ``distributed.LocalCluster`` with 1 and 2 workers (one thread each),
    workers warmed up first; cluster start-up not timed.

Run with the installed package: ``.venv/bin/python benchmarks/bench_sweep.py [--quick]``.
The machine is shared: rates vary with what else runs.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np

from abb_ros.model.dynamics import batch, kernels
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.spindle import ConstantSpeed
from abb_ros.model.parameters.params import DriveParams, apply_settings
from abb_ros.model.stability import floquet
from abb_ros.sweep.compute import warm_up
from abb_ros.sweep.runner import local_cluster, run_sweep
from abb_ros.sweep.spec import parse_spec

DT = 1e-4
LIMIT = 1e-3


def drives(count, seed=0):
    """P3 drives with eps, k, c drawn around the nominal (the tolerance example's spread)."""
    p3, omega = apply_settings(DriveParams(), {'mbar': 0.03, 'c': 0.66, 'wbar': 2.7})
    rng = np.random.default_rng(seed)
    out = [p3.replace(eps=float(np.clip(rng.normal(0.25e-3, 0.05e-3), 0.05e-3, 0.45e-3)),
                      k=float(rng.normal(3972.0, 200.0)),
                      c=float(np.clip(rng.normal(0.66, 0.1), 0.36, 0.96)))
           for _ in range(count)]
    return out, omega


def rate(count, func):
    t0 = time.perf_counter()
    func()
    wall = time.perf_counter() - t0
    return count / wall, wall


# ---- Floquet points ----------------------------------------------------------------------

def floquet_loop(plist, omega):
    for p in plist:
        for plane in ('in', 'out'):
            floquet.max_multiplier_batch([p], [omega], plane, kern=floquet.SERIAL)


def floquet_batched(plist, omega):
    for plane in ('in', 'out'):
        floquet.max_multiplier_batch(plist, [omega] * len(plist), plane, kern=floquet.SERIAL)


# ---- nonlinear runs ----------------------------------------------------------------------

def runs_loop(plist, omega, nsteps):
    S = ConstantSpeed().pack(omega)
    for p in plist:
        y = initial_state(p, omega)
        out = np.empty((nsteps, y.size))
        kernels.JIT.trajectory(y, 0.0, DT, 0, nsteps, 1, kernels.pack_params(p), S,
                               kernels.make_work(p.n), out)
        rbar = np.sqrt(out[:, 1] ** 2 + out[:, 2] ** 2 + out[:, 3] ** 2) / p.R
        above = rbar > LIMIT
        _ = (rbar.max(), above.sum() * DT,
             (np.flatnonzero(above)[-1] + 1) * DT if above.any() else 0.0)


def runs_batched(plist, omega, nsteps):
    y0 = np.array([initial_state(p, omega) for p in plist])
    S = np.array([ConstantSpeed().pack(omega)] * len(plist))
    br = batch.BatchRun(plist, y0, S, DT, LIMIT)
    br.advance(nsteps)
    _ = br.settle_time


# ---- on a LocalCluster -------------------------------------------------------------------

def sweep_spec(samples, stability, duration, partition):
    compute = ({'stability': {'wbar': [2.7]}} if stability else
               {'run': {'duration': duration, 'rbar_limit': LIMIT}})
    return parse_spec({
        'name': 'bench', 'scenario': 'p3',
        'parameters': {
            'eps': {'dist': 'normal', 'mean': 0.25e-3, 'std': 0.05e-3, 'low': 0.05e-3,
                    'high': 0.45e-3},
            'k': {'dist': 'normal', 'mean': 3972.0, 'std': 200.0, 'low': 3372.0,
                  'high': 4572.0},
            'c': {'dist': 'normal', 'mean': 0.66, 'std': 0.1, 'low': 0.36, 'high': 0.96}},
        'samples': samples, 'sampling': {'method': 'sobol', 'seed': 1},
        'partition_size': partition, 'compute': compute})


def cluster_rate(workers, spec):
    from distributed import Client
    cluster = local_cluster(workers)
    client = Client(cluster)
    try:
        client.run(warm_up, spec)
        with tempfile.TemporaryDirectory() as tmp:
            return rate(spec.total, lambda: run_sweep(spec, os.path.join(tmp, 'out'), client))
    finally:
        client.close()
        cluster.close()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='a quarter of the samples')
    args = parser.parse_args()
    q = 4 if args.quick else 1
    n_floq, n_runs, n_cl_floq, n_cl_runs = 400 // q, 48 // q, 1600 // q, 192 // q
    nsteps = int(round(1.0 / DT))
    plist, omega = drives(max(n_floq, n_runs))
    # compile / load every kernel first
    floquet_loop(plist[:2], omega)
    floquet_batched(plist[:2], omega)
    runs_loop(plist[:2], omega, 10)
    runs_batched(plist[:2], omega, 10)

    print(f'[shared 2-core machine, os.cpu_count() = {os.cpu_count()}; '
          f'load average {os.getloadavg()[0]:.1f} at start]')
    res = {}
    res['floq_a'] = rate(n_floq, lambda: floquet_loop(plist[:n_floq], omega))
    res['floq_b'] = rate(n_floq, lambda: floquet_batched(plist[:n_floq], omega))
    res['runs_a'] = rate(n_runs, lambda: runs_loop(plist[:n_runs], omega, nsteps))
    res['runs_b'] = rate(n_runs, lambda: runs_batched(plist[:n_runs], omega, nsteps))
    fspec = sweep_spec(n_cl_floq, True, 0.0, max(1, n_cl_floq // 16))
    rspec = sweep_spec(n_cl_runs, False, 1.0, max(1, n_cl_runs // 16))
    for w in (1, 2):
        res[f'floq_c{w}'] = cluster_rate(w, fspec)
        res[f'runs_c{w}'] = cluster_rate(w, rspec)

    sections = (('floq', 'Floquet points (in + out of plane at one speed, P3 with tolerances)',
                 'point', 'points', (n_floq, n_cl_floq)),
                ('runs', '1 s nonlinear runs (10 kHz RK4, metrics peak rbar, time above, '
                 'settle time)', 'run', 'runs', (n_runs, n_cl_runs)))
    for key, title, one, unit, (n_local, n_cluster) in sections:
        print(f'\n{title}')
        labels = ((f'(a) one {one} per kernel call, loop ({n_local})', 'a'),
                  (f'(b) batched in-process ({n_local})', 'b'),
                  (f'(c) LocalCluster, 1 worker ({n_cluster})', 'c1'),
                  (f'(c) LocalCluster, 2 workers ({n_cluster})', 'c2'))
        for label, case in labels:
            r, wall = res[f'{key}_{case}']
            print(f'  {label:<46s} {r:10.1f} {unit}/s   ({wall:.2f} s)')
        print(f'  (b)/(a) = {res[key + "_b"][0] / res[key + "_a"][0]:.2f}   '
              f'2 workers / 1 worker = {res[key + "_c2"][0] / res[key + "_c1"][0]:.2f}')
    print(f'\n[load average {os.getloadavg()[0]:.1f} at the end]')


if __name__ == '__main__':
    main()

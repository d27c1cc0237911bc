"""Speed of the batched Floquet maps against a per-point scipy solve_ivp (DOP853) monodromy.

Run: ``.venv/bin/python benchmarks/bench_floquet.py [--res 100,200]``. Prints:

1. wall time of a res x res (each of ``--res``) in-plane wbar-mbar map for each ball count
   of ``--balls``
   (default 2 and 10; zeta = 0.025, Fig. 7b ranges; for n >= 3 with the balanced family's
   neutral multipliers removed, floquet_batch.py), everything included (parameter conversion,
   equilibria, harmonics, kernel, eigenvalues)
   except the one-off numba compilation (cached on disk, timed separately), the ratio of
   each map's time to the first one's, and, for n > 3, the multipliers of the same points
   by the reduced six-coordinate system (the maps' path, floquet_reduction.py) against the
   whole (3 + n)-coordinate system (``reduce=False``), timed side by side, with their
   largest difference;
2. the per-point time of the map against DOP853 at the loosest tolerance that still meets
   the 1e-6 accuracy in |lambda|max on a sample (the 'same accuracy' baseline), and
3. a 200-speed sweep (the analysis node's use).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from abb_ros.model.parameters.params import DriveParams, apply_settings
from abb_ros.model.stability import floquet as F
from abb_ros.model.stability.linear import in_plane

TOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8)


def _sample(n, seed=5):
    rng = np.random.default_rng(seed)
    base = DriveParams()
    return [apply_settings(base, {'zeta': 0.025, 'mbar': rng.uniform(0.01, 0.12),
                                  'wbar': rng.uniform(0.2, 3.5)}) for _ in range(n)]


def _reduced_vs_whole(base, xs, ys, n):
    """Time the multipliers of a map's points by the reduced and by the whole system."""
    plist, omegas = [], []
    for yv in ys:
        for xv in xs:
            p, w = apply_settings(base, {'zeta': 0.025, 'n': n, 'mbar': float(yv),
                                         'wbar': float(xv)})
            plist.append(p)
            omegas.append(w)
    lam, wall = {}, {}
    for reduce in (True, False):
        t0 = time.perf_counter()
        lam[reduce] = F.multipliers_batch(plist, omegas, reduce=reduce).lam
        wall[reduce] = time.perf_counter() - t0
    ok = np.isfinite(lam[False])
    print(f'  same points, multipliers only: reduced (6 coordinates) {wall[True]:.2f} s, '
          f'whole ({3 + n} coordinates) {wall[False]:.2f} s: {wall[False] / wall[True]:.1f}x; '
          f'largest |lambda| difference {np.abs(lam[True][ok] - lam[False][ok]).max():.1e}, '
          f'load {os.getloadavg()[0]:.2f}')


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--res', default='200', help='grid sizes of the maps, comma separated')
    ap.add_argument('--sample', type=int, default=12)
    ap.add_argument('--balls', default='2,10', help='ball counts of the maps, comma separated')
    args = ap.parse_args()
    base = DriveParams()
    import numba
    print(f'numba {numba.__version__}, threads {numba.get_num_threads()}, '
          f'cpus {os.cpu_count()}, load {os.getloadavg()[0]:.2f}')

    t0 = time.perf_counter()
    F.sweep_speed(base, [300.0])
    print(f'first call (numba load or compile): {time.perf_counter() - t0:.2f} s')

    per_point = None
    for res in (int(v) for v in args.res.split(',')):
        xs = np.linspace(0.2, 3.5, res)
        ys = np.linspace(0.001, 0.12, res)
        first = None
        for n in (int(v) for v in args.balls.split(',')):
            t0 = time.perf_counter()
            smap = F.stability_map(base, 'wbar', xs, 'mbar', ys, {'zeta': 0.025, 'n': n})
            wall = time.perf_counter() - t0
            npts = smap.lam.size
            n_eq = int((smap.status != F.NO_EQUILIBRIUM).sum())
            if first is None:
                first = (n, wall)
            if first[0] == n:      # the first n's map of the last grid, for the ratio below
                per_point = wall / n_eq
            print(f'{res}x{res} in-plane wbar-mbar map, n = {n}: {wall:.2f} s wall '
                  f'({npts} points, {n_eq} with a balanced equilibrium, '
                  f'{wall / n_eq * 1e6:.0f} us/point, {wall / first[1]:.2f}x the n = '
                  f'{first[0]} map), load {os.getloadavg()[0]:.2f}')
            if n > 3:
                _reduced_vs_whole(base, xs, ys, n)

    # accuracy-matched DOP853 baseline
    pts = _sample(args.sample)
    systems = [in_plane(p, w) for p, w in pts]
    ref = np.array([F.max_multiplier(F.monodromy_reference(s, 1e-12, 1e-12)) for s in systems])
    ours = np.array([F.sweep_speed(p, [w])[0] for p, w in pts])
    print(f'batched RK4 error vs DOP853(1e-12): max {np.abs(ours - ref).max():.1e}')
    chosen = None
    for tol in TOLS:
        t0 = time.perf_counter()
        lam = np.array([F.max_multiplier(F.monodromy_reference(s, tol, tol * 1e-2))
                        for s in systems])
        dt = (time.perf_counter() - t0) / len(systems)
        err = np.abs(lam - ref).max()
        print(f'  DOP853 rtol={tol:.0e}: max error {err:.1e}, {dt * 1e3:.1f} ms/point')
        if err < 1e-6 and chosen is None:
            chosen = (tol, dt)
    tol, dt = chosen
    t0 = time.perf_counter()
    for p, w in pts:
        F.sweep_speed(p, [w])
    single = (time.perf_counter() - t0) / len(pts)
    print(f'per-point ratio, map (batched, first n) vs DOP853 rtol={tol:.0e}: '
          f'{dt / per_point:.0f}x')
    print(f'per-point ratio, one point per call vs DOP853: {dt / single:.0f}x '
          f'({single * 1e3:.2f} ms/call)')

    p, _ = apply_settings(base, {'zeta': 0.025, 'mbar': 0.03})
    omegas = np.linspace(0.2, 3.5, 200) * p.omega0
    t0 = time.perf_counter()
    F.sweep_speed(p, omegas)
    print(f'200-speed sweep (in-plane): {time.perf_counter() - t0:.3f} s')


if __name__ == '__main__':
    main()

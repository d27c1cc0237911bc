"""Headless speed of the nonlinear model (the physics core).

Prints, for n = 2 and n = 10 at P3 (metal washers, wbar = 2.7):
- the real-time factor (simulated s per wall s) of the compiled fixed-step RK4 at the node's
  default step (abb_ros.model.dynamics.integrate.DEFAULT_DT), integration alone;
- scipy solve_ivp (DOP853, rtol 1e-9, atol 1e-12 m-scale) on the same run, same right-hand
  side (the compiled one, so the comparison is of integrators, not of Python vs numba), and
  the loosest DOP853 tolerance that is at least as accurate as RK4, with the speed ratio;
- the errors of each against a tight reference (DOP853, rtol 1e-12);
- for scale, DOP853 with the right-hand side in plain Python (the kernels' uncompiled twin);
- the adaptive Dormand-Prince 5(4) integrator (``integrator='adaptive'``, sampled at the same
  1 kHz stamps by its dense output) beside RK4: on the same run with its error and
  right-hand-side count, and on 10 s of P3 (the target: 2.5x RK4's speed for n = 2, 2x for
  n = 10);
- a long run of the Table 1 drive at P3 (scenario p3): 20 s of steps after 130 s, where the
  out-of-plane velocities have decayed below the smallest normal double, with those
  subnormals kept through one kernel call and with them set to 0 as Simulation does after
  each call (integrate.SMALLEST_NORMAL);
- sweep runs per core: 1 s P3 runs of drives with eps, k, c spread, by the batched RK4 kernel
  (``batch.BatchRun``) and by the adaptive integrator (``batch.AdaptiveRuns``), one thread.
solve_ivp costs ~10 us of Python per right-hand-side call whatever the model, and DOP853 needs
about half the evaluations of RK4 at 10 kHz, so against the compiled right-hand side the ratio
is bounded near 20x for n = 2; the plain-Python ratio is what replacing a scipy model buys.
Nothing is asserted: these machines are shared and noisy; ratios are measured in one process.

Run: .venv/bin/python benchmarks/bench_core.py [--seconds 2]
"""

import argparse
import os
import time

import numpy as np

from abb_ros.model.dynamics import batch, kernels
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.dynamics.reference import reference_solution
from abb_ros.model.dynamics.spindle import ConstantSpeed
from abb_ros.model.parameters.params import METAL_C, DriveParams, apply_settings


def _best_of(fn, repeats=3):
    best = np.inf
    out = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def bench(n, seconds):
    params, omega = apply_settings(DriveParams(), {'mbar': 0.03 * 2 / n, 'c': METAL_C,
                                                   'wbar': 2.7, 'n': n})
    y0 = initial_state(params, omega)
    nsteps = int(round(seconds / DEFAULT_DT))
    N = 7 + n

    every = int(round(1e-3 / DEFAULT_DT))          # compare at every millisecond
    t_eval = np.arange(1, nsteps // every + 1) * every * DEFAULT_DT

    def rk4():
        sim = Simulation(params, omega, DEFAULT_DT, spindle=ConstantSpeed(), y0=y0)
        return sim.trajectory(nsteps, every).T

    rk4()  # compile
    t_rk4, y_rk4 = _best_of(rk4)
    ref = reference_solution(params, y0, (0, seconds), t_eval=t_eval, rtol=1e-12,
                             atol=1e-15).y

    def err(y):  # max deck translation error over the run, relative to the 0.3 mm start
        return np.abs(y[1:4] - ref[1:4]).max() / 0.3e-3

    def dop(rtol):
        return reference_solution(params, y0, (0, seconds), t_eval=t_eval, rtol=rtol,
                                  atol=rtol * 1e-3)

    t_dop9, r9 = _best_of(lambda: dop(1e-9), repeats=2)
    # loosest tolerance at least as accurate as RK4 at the default step
    e_rk4 = err(y_rk4)
    match = None
    for rtol in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10):
        r = dop(rtol)
        if err(r.y) <= e_rk4:
            match = rtol
            break
    t_match, rm = _best_of(lambda: dop(match), repeats=2)
    print(f'n = {n:2d}  ({seconds:g} s of P3, {nsteps} RK4 steps of {DEFAULT_DT * 1e6:g} us, '
          f'N = {N} coordinates)')
    print(f'  RK4 compiled, default step : {t_rk4:8.4f} s wall   real-time factor '
          f'{seconds / t_rk4:8.1f}x   error {e_rk4:.1e}')
    def adaptive(span=nsteps):
        sim = Simulation(params, omega, DEFAULT_DT, spindle=ConstantSpeed(), y0=y0,
                         integrator='adaptive')
        return sim.trajectory(span, every).T, sim.adaptive_counts['nfev']

    adaptive(every)  # compile
    t_ad, (y_ad, nfev_ad) = _best_of(adaptive)
    print(f'  adaptive DP5(4) compiled   : {t_ad:8.4f} s wall   real-time factor '
          f'{seconds / t_ad:8.1f}x   error {err(y_ad):.1e}   nfev {nfev_ad} (RK4 {4 * nsteps})'
          f'   {t_rk4 / t_ad:5.1f}x RK4\'s speed   load {os.getloadavg()[0]:.2f}')
    long = int(round(10.0 / DEFAULT_DT))
    t_rk4_10, _ = _best_of(lambda: Simulation(params, omega, DEFAULT_DT, spindle=ConstantSpeed(),
                                              y0=y0).trajectory(long, every), repeats=2)
    t_ad_10, _ = _best_of(lambda: adaptive(long), repeats=2)
    print(f'  10 s of P3                 : RK4 {t_rk4_10:.4f} s, adaptive {t_ad_10:.4f} s wall:'
          f' adaptive {t_rk4_10 / t_ad_10:5.1f}x RK4\'s speed   load {os.getloadavg()[0]:.2f}')
    print(f'  solve_ivp DOP853 rtol 1e-9 : {t_dop9:8.4f} s wall   real-time factor '
          f'{seconds / t_dop9:8.1f}x   error {err(r9.y):.1e}   nfev {r9.nfev}'
          f'   RK4 is {t_dop9 / t_rk4:6.1f}x faster')
    print(f'  solve_ivp DOP853 rtol {match:.0e} : {t_match:8.4f} s wall   (as accurate as RK4: '
          f'error {err(rm.y):.1e}, nfev {rm.nfev})   RK4 is {t_match / t_rk4:6.1f}x '
          f'faster')
    # The same DOP853 run with the right-hand side in plain Python (the kernels' uncompiled
    # twin, i.e. the model as one would write it for scipy): timed on a tenth of the run.
    short = seconds / 10
    t_py, r_py = _best_of(lambda: reference_solution(params, y0, (0, short), t_eval=[short],
                                                      rtol=1e-9, atol=1e-12,
                                                      kern=kernels.PY), repeats=1)
    print(f'  solve_ivp DOP853 rtol 1e-9, Python right-hand side: {t_py * 10:8.2f} s wall '
          f'(extrapolated from {short:g} s, nfev {r_py.nfev})   RK4 is '
          f'{t_py * 10 / t_rk4:7.0f}x faster')


def sweep_runs(count=24, seconds=1.0):
    """Time 1 s P3 runs of spread drives by the batched RK4 kernel and by the adaptive one."""
    p3, omega = apply_settings(DriveParams(), {'mbar': 0.03, 'c': METAL_C, 'wbar': 2.7})
    rng = np.random.default_rng(0)
    plist = [p3.replace(eps=p3.eps * rng.uniform(0.4, 1.6), k=p3.k * rng.uniform(0.9, 1.1),
                        c=p3.c * rng.uniform(0.6, 1.4)) for _ in range(count)]
    y0 = np.array([initial_state(p, omega) for p in plist])
    nsteps = int(round(seconds / DEFAULT_DT))

    def rk4(k=count, steps=nsteps):
        S = np.array([ConstantSpeed().pack(omega)] * k)
        batch.BatchRun(plist[:k], y0[:k], S, DEFAULT_DT, 1e-3).advance(steps)

    def adaptive(k=count, steps=nsteps):
        batch.AdaptiveRuns(plist[:k], y0[:k], ConstantSpeed(), omega, DEFAULT_DT,
                           1e-3).advance(steps)

    rk4(1, 10)
    adaptive(1, 10)
    t_rk4, _ = _best_of(rk4, repeats=2)
    t_ad, _ = _best_of(adaptive, repeats=2)
    print(f'sweep runs, one thread ({count} drives, {seconds:g} s of P3 each, metrics at '
          f'every step of {DEFAULT_DT * 1e6:g} us)')
    print(f'  batched RK4 (BatchRun)     : {count / t_rk4:8.1f} runs/s   ({t_rk4:.2f} s)')
    print(f'  adaptive (AdaptiveRuns)    : {count / t_ad:8.1f} runs/s   ({t_ad:.2f} s)   '
          f'{t_rk4 / t_ad:5.1f}x per core   load {os.getloadavg()[0]:.2f}')


def subnormal_cost(seconds=20.0, settle_s=130.0, repeats=3):
    """Time ``seconds`` of P3 from the state after ``settle_s``: subnormals kept vs flushed."""
    from abb_ros.io.files.scenario import load_scenario
    from abb_ros.model.dynamics.integrate import SMALLEST_NORMAL
    scenario = load_scenario('p3')

    def simulation(y0=None):
        return Simulation(scenario.params, scenario.omega, DEFAULT_DT,
                          spindle=scenario.spindle, y0=y0)

    per_s = int(round(1.0 / DEFAULT_DT))
    flushed = simulation()
    flushed.advance(per_s * int(settle_s))   # flushed at the end of the call
    # the same settling in one call of the compiled stepping, which leaves the decayed
    # coordinates where they stall, among the subnormals
    kept = simulation()
    advance = kept.kern.paper_advance if kept.on_paper() else kept.kern.advance
    advance(kept.y, kept.t0, kept.dt, 0, per_s * int(settle_s), kept._P, kept._S, kept._work)
    stalled = int(((kept.y != 0) & (np.abs(kept.y) < SMALLEST_NORMAL)).sum())

    def run(y0):
        simulation(y0.copy()).advance(int(seconds * per_s))   # one call: flushed at its end

    t_kept, _ = _best_of(lambda: run(kept.y), repeats)
    t_flushed, _ = _best_of(lambda: run(flushed.y), repeats)
    print(f'long run (Table 1, P3): {seconds:g} s after {settle_s:g} s; {stalled} coordinates '
          f'stalled among the subnormals without the flush')
    print(f'  subnormals kept   : {t_kept:8.4f} s wall   real-time factor {seconds / t_kept:7.1f}')
    print(f'  flushed to 0      : {t_flushed:8.4f} s wall   real-time factor '
          f'{seconds / t_flushed:7.1f}   kept / flushed cost = {t_kept / t_flushed:.2f}')


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--seconds', type=float, default=2.0)
    args = parser.parse_args()
    print(f'{os.cpu_count()} cores, load {os.getloadavg()[0]:.2f} at start')
    for n in (2, 10):
        bench(n, args.seconds)
    subnormal_cost()
    sweep_runs()


if __name__ == '__main__':
    main()

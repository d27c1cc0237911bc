"""Headless speed of the nonlinear model (the physics core).

Prints, for n = 2 and n = 10 at P3 (metal washers, wbar = 2.7):
- the real-time factor (simulated s per wall s) of the compiled fixed-step RK4 at the node's
  default step (abb_ros.model.dynamics.integrate.DEFAULT_DT), integration alone;
- scipy solve_ivp (DOP853, rtol 1e-9, atol 1e-12 m-scale) on the same run, same right-hand
  side (the compiled one, so the comparison is of integrators, not of Python vs numba), and
  the loosest DOP853 tolerance that is at least as accurate as RK4, with the speed ratio;
- the errors of each against a tight reference (DOP853, rtol 1e-12);
- for scale, DOP853 with the right-hand side in plain Python (the kernels' uncompiled twin).
solve_ivp costs ~10 us of Python per right-hand-side call whatever the model, and DOP853 needs
about half the evaluations of RK4 at 10 kHz, so against the compiled right-hand side the ratio
is bounded near 20x for n = 2; the plain-Python ratio is what replacing a scipy model buys.
Nothing is asserted: these machines are shared and noisy; ratios are measured in one process.

Run: .venv/bin/python benchmarks/bench_core.py [--seconds 2]
"""

import argparse
import time

import numpy as np

from abb_ros.model.dynamics import kernels
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--seconds', type=float, default=2.0)
    args = parser.parse_args()
    for n in (2, 10):
        bench(n, args.seconds)


if __name__ == '__main__':
    main()

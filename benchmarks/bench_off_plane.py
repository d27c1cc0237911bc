"""Cost of mass centres off the washers' plane and a leaning rotor axis (docs/equations.md F4, F6).

Side by side in one process, P3 (metal washers, wbar = 2.7, n = 2 and 10), the node's fixed
RK4 step: the paper's path (all offsets zero: ``on_paper``, the block-triangular deck solve)
against the general path with the heights z_P, z_G, z_B and the lean tau (the coupled 6 x 6
deck solve, the extra row terms). Prints the real-time factor of each and their ratio (the
issue's bound: the general path at most 1.5x the paper's per simulated second), then the
coupled analysis: one point (lam_max and the predicted residual tilt) and the analysis node's
table of 300 speeds, beside the plane's Floquet table of the same drive.
Nothing is asserted: these machines are shared and noisy; ratios are measured in one run.

Run: .venv/bin/python benchmarks/bench_off_plane.py [--seconds 2]
"""

import argparse
import time

import numpy as np

from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.dynamics.spindle import ConstantSpeed
from abb_ros.model.parameters.params import METAL_C, DriveParams, apply_settings
from abb_ros.model.stability import coupled, speed_bands

OFFSETS = {'z_P': 0.004, 'z_G': 0.001, 'z_B': -0.0005, 'tau': 0.002, 'psi_tau': 0.5}


def best_of(fn, repeats=3):
    """Return the least wall time of ``repeats`` calls of fn [s]."""
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def drive(n, offsets):
    return apply_settings(DriveParams(), {'mbar': 0.03 * 2 / n, 'c': METAL_C, 'wbar': 2.7,
                                          'n': n, **offsets})


def simulation_rate(n, offsets, seconds):
    """Return simulated seconds per wall second of the fixed RK4 at DEFAULT_DT."""
    params, omega = drive(n, offsets)
    y0 = initial_state(params, omega)
    nsteps = int(round(seconds / DEFAULT_DT))

    def run():
        Simulation(params, omega, DEFAULT_DT, spindle=ConstantSpeed(), y0=y0).advance(nsteps)

    run()                    # compile or load
    return seconds / best_of(run)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--seconds', type=float, default=2.0, help='simulated seconds per run')
    args = ap.parse_args()
    print(f'simulation, fixed RK4 at {1 / DEFAULT_DT:.0f} Hz, {args.seconds:g} s of P3 '
          f'(offsets {OFFSETS})')
    for n in (2, 10):
        paper = simulation_rate(n, {}, args.seconds)
        general = simulation_rate(n, OFFSETS, args.seconds)
        print(f'  n = {n:2d}: paper path {paper:7.1f} x real time, with offsets '
              f'{general:7.1f} x real time: general / paper cost = {paper / general:.2f}')
    params, omega = drive(2, OFFSETS)
    plane, _ = drive(2, {})
    t_point = best_of(lambda: coupled.coupled_stability(params, omega), 3)
    t_tilt = best_of(lambda: coupled.residual_tilt(params, omega), 3)
    t_table = best_of(lambda: speed_bands.speed_table(params, 1500.0), 2)
    t_plane = best_of(lambda: speed_bands.speed_table(plane, 1500.0), 2)
    print(f'coupled analysis (n = 2): lam_max at one speed {t_point * 1e3:.0f} ms, predicted '
          f'residual tilt {t_tilt * 1e3:.0f} ms; table of {speed_bands.TABLE_POINTS} speeds '
          f'{t_table:.2f} s (the plane\'s Floquet table {t_plane:.2f} s: ratio '
          f'{t_table / t_plane:.1f})')


if __name__ == '__main__':
    main()

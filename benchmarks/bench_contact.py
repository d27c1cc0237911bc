"""Real-time factor of the fixed-step RK4 with and without contact and rolling (n = 10).

P3 with ten balls (config/scenarios/p3_n10_scattered.yaml: m = 0.156 g each, wbar = 2.7, metal
washers, the scattered start that leaves room for balls of steel size, r_ball = 1.67 mm), at
the node's default step (10 kHz), integration alone (the compiled kernels), for: - the paper's
model; - steel balls with Hertzian contact; - contact + rolling resistance (1e-6 m) +
rolling-ball spin inertia; - the same from a chain start (ten balls touching side by side at
0.1 deg beyond contact: contact sub-steps in many steps while they part); - P1 (wbar = 0.8)
from the scattered start, paper model vs contact: the balls gather into a touching chain (the
worst case: ~60 sub-steps per step while they settle, 0.3-1 s), then stay in contact at rest (7
sub-steps per step): timed over the first 2 s, and over 2 s after 1.5 s of settling. The node
keeps real time when the factor is above 1 (its own overhead: see
benchmarks/bench_simulator_node.py). "RK4 steps per step" (sub-steps included, counted over the
whole run with its settling) is the machine-independent cost; in a multirate contact step
(kernels.multirate.mis_contact_step: speed-driven spindle, no rolling resistance) it counts the
fast sub-steps, each O(n), not a solve of the coupled system; "rolling switches" counts the
stick/slip switches located inside steps (over the whole run). Nothing is asserted (shared,
noisy machines).

``--dt`` runs every line at another step (e.g. 1e-5 s: contacts resolved in one RK4 step, each
checked for a misjudged impact, kernels.contact_steps.retake_substeps; the settling then takes
as many more steps).

Run: nice -n 10 .venv/bin/python benchmarks/bench_contact.py [--seconds 2] [--dt 1e-4]
"""

import argparse
import math
import time

import numpy as np

from abb_ros.io.files.scenario import load_scenario
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.dynamics.spindle import ConstantSpeed
from abb_ros.model.parameters.ball_materials import with_steel_balls


def _rtf(params, omega, phi0, seconds, settle=0.0, dt=DEFAULT_DT):
    """Best of two real-time factors over ``seconds`` at steps of dt, after ``settle`` s
    untimed.
    """
    y0 = initial_state(params, omega, phi0=phi0)
    nsteps = int(round(seconds / dt))
    best = math.inf
    sim = None
    for _ in range(2):
        sim = Simulation(params, omega, dt, spindle=ConstantSpeed(), y0=y0)
        sim.advance(1 + int(round(settle / dt)))      # compile, settle: not timed
        t0 = time.perf_counter()
        sim.advance(nsteps)
        best = min(best, time.perf_counter() - t0)
    return seconds / best, sim


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--seconds', type=float, default=2.0)
    parser.add_argument('--dt', type=float, default=DEFAULT_DT, help='step [s]')
    args = parser.parse_args()
    scenario = load_scenario('p3_n10_scattered')
    paper = scenario.params
    steel = with_steel_balls(paper)
    full = with_steel_balls(paper, rolling_mu=1e-6, rotation=True)
    chain = np.arange(10) * (steel.contact_separation + math.radians(0.1))
    print(f'n = 10, P3, {args.seconds:g} s per run, RK4 at {args.dt * 1e6:g} us, '
          f'r_ball = {steel.r_ball * 1e3:.3f} mm')
    p1 = 0.8 * paper.omega0
    for label, params, phi0, omega, settle in (
            ('paper model', paper, scenario.phi0, scenario.omega, 0.0),
            ('contact', steel, scenario.phi0, scenario.omega, 0.0),
            ('contact + rolling + rotation', full, scenario.phi0, scenario.omega, 0.0),
            ('contact + rolling + rotation, chain start', full, chain, scenario.omega, 0.0),
            ('P1: paper model', paper, scenario.phi0, p1, 0.0),
            ('P1: contact, balls gathering', steel, scenario.phi0, p1, 0.0),
            ('P1: contact, chain at rest (after 1.5 s)', steel, scenario.phi0, p1, 1.5)):
        rtf, sim = _rtf(params, omega, phi0, args.seconds, settle, args.dt)
        steps = sim.steps
        per_step = (steps - sim.refined_steps + sim.substeps) / steps
        print(f'  {label:42s} real-time factor {rtf:7.2f}x   RK4 steps per step '
              f'{per_step:6.2f}   refined steps {sim.refined_steps:6d}   max sub-steps '
              f'{sim.max_substeps:3d}   rolling switches {sim.rolling_switches}')


if __name__ == '__main__':
    main()

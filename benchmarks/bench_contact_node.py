"""Does the simulator node keep real time at n = 10 with ball contact? (prints figures;
asserts nothing)

The worst case of the ball model: ten steel balls (m = 0.156 g, r_ball = 1.680 mm,
contact_E = 2e11 Pa, D = 1e-6, c = 0.66) at P1 (wbar = 0.8) from the node's default start.
They gather into a touching chain in the first ~0.8 s, with impacts in every step from
~0.45 s, then rest in it (every step refined). The same drive with the paper's model (point
balls) is the baseline.

For each model, ``--runs`` times, the node runs in its own process at real_time_factor 1 (10 kHz
steps, 1 kHz publish) for ``--duration`` s. From its ``/diagnostics`` this prints:
- slips: the times it fell more than max_stamp_lag behind and dropped periods (target 0);
- the late periods it caught up (overruns);
- the real-time factor since its start;
- the steps refined by contact.

It also prints the CPU of the node process, averaged over the whole run, its start-up
included. The integration alone, measured in this process
over the same first 2 s (Simulation.advance in 1 ms periods), is printed next to it as the
node's budget.

    nice -n 10 .venv/bin/python benchmarks/bench_contact_node.py [--duration 10] [--runs 3]
"""

import argparse
import os
import time

from bench_simulator_node import STEPS_PER_MS, Probe, cpu_seconds, start_node, stop_node

from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.parameters.ball_materials import with_steel_balls
from abb_ros.model.parameters.params import DriveParams

PAPER = DriveParams().replace(m=1.56e-4, D=1.0e-6, n=10, c=0.66)
STEEL = with_steel_balls(PAPER)
OMEGA = 0.8 * PAPER.omega0
"""P1: wbar = 0.8."""


def node_params(params: DriveParams) -> list[str]:
    names = ('m', 'D', 'c', 'r_ball', 'contact_E', 'contact_nu')
    return [f'drive.{k}:={getattr(params, k)!r}' for k in names] + [
        f'spindle.initial_speed:={OMEGA!r}', 'real_time_factor:=1.0']


def run_node(ns: str, params: DriveParams, seconds: float) -> dict:
    proc = start_node(ns, *node_params(params))
    probe = Probe(ns, subscribe_states=False)
    try:
        wall0 = time.perf_counter()
        probe.wait_diag()
        probe.spin_for(max(0.0, seconds - (time.perf_counter() - wall0)))
        cpu = cpu_seconds(proc.pid) / (time.perf_counter() - wall0)
        _, diag = probe.diag
    finally:
        rc = stop_node(proc)
        probe.close()
    return dict(sim_time=float(diag['sim_time']), slips=int(diag['slips']),
                overruns=int(diag['overruns']),
                rtf=float(diag['real_time_factor_since_start']),
                refined=int(diag.get('contact_refined_steps', 0)), cpu=cpu, exit_code=rc)


def integration_alone(params: DriveParams, seconds: float = 2.0) -> float:
    """Real-time factor of Simulation.advance over the first ``seconds`` of simulated time."""
    sim = Simulation(params, OMEGA, DEFAULT_DT)
    sim.advance(1)                                  # load the compiled kernels
    wall0 = time.perf_counter()
    for _ in range(int(round(seconds / 1e-3))):
        sim.advance(STEPS_PER_MS)
    return (sim.t - DEFAULT_DT) / (time.perf_counter() - wall0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--duration', type=float, default=10.0, help='seconds per node run')
    ap.add_argument('--runs', type=int, default=3, help='node runs per model')
    args = ap.parse_args()
    print(f'n = 10, P1 (omega {OMEGA:.1f} rad/s), 10 kHz steps, 1 kHz publish, '
          f'real_time_factor 1, {args.duration:.0f} s per run, {os.cpu_count()} CPUs, '
          f'load average {os.getloadavg()[0]:.2f}')
    for name, params in (('paper model', PAPER), ('contact (steel balls)', STEEL)):
        print(f'{name}: integration alone over the first 2 s: real-time factor '
              f'{integration_alone(params):.2f}x')
        for run in range(args.runs):
            r = run_node(f'/bench_contact_{run}', params, args.duration)
            print(f'  node run {run + 1}: slips {r["slips"]}   overruns {r["overruns"]:5d}   '
                  f'real-time factor since start {r["rtf"]:.3f} (sim_time {r["sim_time"]:.2f} s)'
                  f'   refined steps {r["refined"]:6d}   CPU {100 * r["cpu"]:.0f} %   '
                  f'exit {r["exit_code"]}')
    print(f'load average {os.getloadavg()[0]:.2f} at the end')


if __name__ == '__main__':
    main()

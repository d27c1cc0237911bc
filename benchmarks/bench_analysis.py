"""Speed of the analysis node (prints figures; asserts nothing).

1. Table (re)compute time, in this process: ``speed_table`` (300 speeds, in- and out-of-plane,
   batched kernel) for the P3 drive with 2 and 10 balls, against the baseline of one
   ``point_stability`` call per speed.
2. Status latency over a speed ramp: the simulator (real time, joint_states at 1 kHz) and the
   analysis node as subprocesses over DDS; the spindle ramps P1 -> P3 (wbar 0.8 -> 2.7) at
   ACCEL rad/s^2; for every joint_states, the wall time until the first status that reflects
   it (its stamp or a later one) arrives here. Baseline: the in-process cost of one verdict
   (``assess`` on the table), i.e. what is not transport or throttling.

Run: ``.venv/bin/python benchmarks/bench_analysis.py [--accel 200] [--points 300]``
"""

import argparse
import os
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from abb_ros.io.files.drive_file import write_drive_yaml
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.stability.floquet import point_stability
from abb_ros.model.stability.speed_bands import assess, speed_table
from abb_ros.testing.latency import status_delays

ROOT = Path(__file__).resolve().parents[1]

P3 = DriveParams(c=0.66, m=0.03 * 0.026)


def best_of(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def bench_table(points):
    speed_table(P3, 1500.0, 16)  # load the compiled kernel (numba disk cache)
    omegas = np.linspace(1500.0 / points, 1500.0, points)
    print(f'1. speed table, {points} speeds over 0-1500 rad/s (best of 3)')
    for n in (2, 10):
        p = P3.replace(n=n, m=P3.m * 2 / n)
        table_s = best_of(lambda: speed_table(p, 1500.0, points))
        naive_s = best_of(lambda: [point_stability(p, w) for w in omegas], repeat=1)
        print(f'   n = {n:2d}: speed_table {table_s * 1e3:7.1f} ms; one point_stability per '
              f'speed {naive_s * 1e3:7.1f} ms; ratio {naive_s / table_s:5.1f}x')
    table = speed_table(P3, 1500.0, points)
    w = np.random.default_rng(0).uniform(1.0, 1500.0, 2000)
    t0 = time.perf_counter()
    for x in w:
        assess(table, float(x))
    return (time.perf_counter() - t0) / w.size


def bench_latency(accel, assess_s):
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    w0 = P3.omega0
    js, st = [], []

    def stamp(msg):
        return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec

    def on_diag(msg):
        # Verdicts on the simulator's parameters only: until the analysis has copied them
        # (GetParameters, once it sees the simulator) it judges its own, and the copy then
        # recomputes the table (STALE meanwhile), which is not a latency of the verdicts.
        for s in msg.status:
            synced = any(kv.key == 'parameters_from' and not kv.value.startswith('own')
                         for kv in s.values)
            if (s.name.endswith('abb_analysis: stability') and s.level != DiagnosticStatus.STALE
                    and synced):
                st.append((time.monotonic(), stamp(msg)))

    with tempfile.TemporaryDirectory() as tmp:
        params = Path(tmp) / 'p3.yaml'
        write_drive_yaml(P3, params)
        procs = [subprocess.Popen(
            [sys.executable, '-m', f'abb_ros.nodes.{name}', '--ros-args', '--params-file',
             str(params), *extra], cwd=ROOT, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
            for name, extra in (('simulator', ['-p', f'spindle.initial_speed:={0.8 * w0}',
                                               '-p', f'spindle.max_accel:={accel}']),
                                ('analysis', []))]
        ctx = Context()
        rclpy.init(context=ctx)
        node = Node('bench_analysis_probe', context=ctx)
        node.create_subscription(JointState, 'joint_states',
                                 lambda m: js.append((time.monotonic(), stamp(m))), 1000)
        node.create_subscription(DiagnosticArray, '/diagnostics', on_diag, 1000)
        cmd = node.create_publisher(Float64, 'spindle/speed_cmd', 10)
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        thread = threading.Thread(target=executor.spin, daemon=True)
        thread.start()
        try:
            deadline = time.monotonic() + 90
            while not (js and st) and time.monotonic() < deadline:
                time.sleep(0.05)
            ramp_s = (2.7 - 0.8) * w0 / accel
            start = time.monotonic()
            cmd.publish(Float64(data=2.7 * w0))
            time.sleep(ramp_s + 0.5)
        finally:
            executor.shutdown()
            node.destroy_node()
            rclpy.try_shutdown(context=ctx)
            for p in procs:
                p.send_signal(signal.SIGINT)
            for p in procs:
                try:
                    p.wait(timeout=15)
                except subprocess.TimeoutExpired:
                    p.kill()
    js = [j for j in js if j[0] >= start]
    st = [s for s in st if s[0] >= start]
    d = np.array(status_delays(js, st)) * 1e3
    print(f'2. status latency over a {ramp_s:.1f} s ramp P1 -> P3 ({accel:g} rad/s^2), '
          f'{d.size} joint_states, {len(st)} statuses ({len(st) / (ramp_s + 0.5):.0f}/s)')
    print(f'   p50 {np.percentile(d, 50):6.1f} ms   p99 {np.percentile(d, 99):6.1f} ms   '
          f'max {d.max():6.1f} ms   (target 50 ms; publish throttle 20 ms)')
    print(f'   baseline: one verdict in-process {assess_s * 1e6:.0f} us; p50 latency / '
          f'verdict cost = {np.percentile(d, 50) * 1e-3 / assess_s:.0f}x')


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--accel', type=float, default=200.0, help='spindle ramp [rad/s^2]')
    ap.add_argument('--points', type=int, default=300, help='speeds in the table')
    args = ap.parse_args()
    assess_s = bench_table(args.points)
    bench_latency(args.accel, assess_s)


if __name__ == '__main__':
    main()

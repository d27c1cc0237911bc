"""Cost of the HIL I/O: FG speed sensor, sensor faults, markers (prints figures; asserts
nothing).

1. In this process, per call: SpeedSensor.update at 1 kHz samples of a drive at P3 speed,
   SpeedFaults.apply and ImuFaults.apply (inactive and active), marker_array (CDR bytes,
   n = 2, 10),
   and rclpy's publish of a Float64 and of the n = 2 MarkerArray's bytes (no subscriber).
2. The simulator node in its own process, real time (real_time_factor 1, 10 kHz / 1 kHz,
   n = 2), no subscriber: CPU of the node process (/proc/<pid>/stat utime + stime) over a
   window, with visualization.rate_hz 0 (markers off), 20 (default) and 100; with
   ``--baseline-root DIR``, also the node of another checkout (e.g. ``git archive`` of the
   commit before the bench I/O), whose python -m abb_ros.nodes.simulator is then run from DIR.

    .venv/bin/python benchmarks/bench_hil_io.py [--duration 20] [--baseline-root DIR]
"""

import argparse
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from bench_simulator_node import cpu_seconds

from abb_ros.io.wire.markers import marker_array
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.sensors.faults import ImuFaults, SpeedFaults
from abb_ros.model.sensors.imu import ImuReading
from abb_ros.model.sensors.speed_sensor import SpeedSensor

ROOT = Path(__file__).resolve().parents[1]
WARM_UP_S = 8.0


def per_call_us(fn, count):
    start = time.perf_counter()
    for i in range(count):
        fn(i)
    return (time.perf_counter() - start) / count * 1e6


def in_process():
    omega = 2.7 * DriveParams().omega0
    warm = SpeedSensor(seed=1)     # the FG kernel's first call loads it from the cache
    for i in range(2):
        warm.update(i * 1e-3, omega * i * 1e-3, omega)
    sensor = SpeedSensor(seed=1)
    us = per_call_us(lambda _i: sensor.update(i * 1e-3, omega * i * 1e-3, omega), 20000)
    print(f'  SpeedSensor.update (1 kHz, omega {omega:.0f} rad/s, '
          f'{sensor.edges / 20:.0f} edges/s)   {us:6.2f} us/sample')
    faults = SpeedFaults(seed=1)
    print(f'  SpeedFaults.apply, none active              '
          f'{per_call_us(lambda _i: faults.apply(100.0), 20000):6.2f} us')
    faults.noise = 1.0
    print(f'  SpeedFaults.apply, noise                    '
          f'{per_call_us(lambda _i: faults.apply(100.0), 20000):6.2f} us')
    reading = ImuReading(np.ones(3), np.ones(3))
    imu = ImuFaults()
    print(f'  ImuFaults.apply, none active                '
          f'{per_call_us(lambda _i: imu.apply(reading), 20000):6.2f} us')
    imu.accel_bias_step = (0.1, 0.0, 0.0)
    print(f'  ImuFaults.apply, bias step                  '
          f'{per_call_us(lambda _i: imu.apply(reading), 20000):6.2f} us')
    for n in (2, 10):
        p = DriveParams(n=n)
        y = initial_state(p, omega)
        encoded = marker_array(0, y, p, 100.0)
        if n == 2:
            two = encoded
        print(f'  marker_array (CDR bytes), n = {n:2d}            '
              f'{per_call_us(lambda _i: marker_array(i, y, p, 100.0), 2000):6.1f} us')
    return two


def publish_costs(markers):
    import rclpy
    from rclpy.node import Node
    from std_msgs.msg import Float64
    from visualization_msgs.msg import MarkerArray
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = Node(f'bench_io_{os.getpid()}', context=ctx)
    try:
        speed = node.create_publisher(Float64, 'bench_io/speed', 10)
        msg = Float64(data=1.0)
        print(f'  publish Float64 (spindle/speed)             '
              f'{per_call_us(lambda _i: speed.publish(msg), 20000):6.2f} us')
        pub = node.create_publisher(MarkerArray, 'bench_io/markers', 10)
        print(f'  publish MarkerArray (CDR bytes), n = 2      '
              f'{per_call_us(lambda _i: pub.publish(markers), 2000):6.1f} us')
    finally:
        node.destroy_node()
        rclpy.shutdown(context=ctx)


def node_cpu(rate_hz: float, duration: float, root: Path = ROOT) -> float:
    args = [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args', '-r',
            f'__ns:=/bench_io_{os.getpid()}', '-p', f'visualization.rate_hz:={rate_hz}']
    proc = subprocess.Popen(args, cwd=root, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        time.sleep(WARM_UP_S)
        c0, t0 = cpu_seconds(proc.pid), time.monotonic()
        time.sleep(duration)
        c1, t1 = cpu_seconds(proc.pid), time.monotonic()
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=20)
    return (c1 - c0) / (t1 - t0) * 100.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--duration', type=float, default=20.0)
    parser.add_argument('--repeat', type=int, default=2)
    parser.add_argument('--baseline-root', type=Path)
    args = parser.parse_args()
    print('[in process, per call]')
    publish_costs(in_process())
    print(f'[node, real time, n = 2, {args.duration:g} s windows, load average '
          f'{os.getloadavg()[0]:.1f}]')
    results = {}
    settings = [(rate, ROOT) for rate in (0.0, 20.0, 100.0)]
    if args.baseline_root:
        settings.insert(0, ('baseline', args.baseline_root))
    for _ in range(args.repeat):        # interleaved: load changes hit every setting alike
        for rate, root in settings:
            results.setdefault(rate, []).append(
                node_cpu(0.0 if rate == 'baseline' else rate, args.duration, root))
    for rate, cpu in results.items():
        label = ('baseline checkout' if rate == 'baseline' else
                 'markers off' if rate == 0 else f'markers at {rate:g} Hz')
        print(f'  CPU of the node, {label:17s} '
              + ', '.join(f'{c:5.1f} %' for c in cpu) + ' of one core')
    base = min(results[0.0])
    print(f'  (min-to-min difference: 20 Hz {min(results[20.0]) - base:+.1f} points, '
          f'100 Hz {min(results[100.0]) - base:+.1f} points; load average now '
          f'{os.getloadavg()[0]:.1f})')
    return 0 if math.isfinite(base) else 1


if __name__ == '__main__':
    sys.exit(main())

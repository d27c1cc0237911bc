"""Speed of the simulator node (prints figures; asserts nothing).

Real time (real_time_factor 1, n = 10, default rates 10 kHz / 1 kHz), the node in its own
process, a subscriber in this one:
  achieved real-time factor and overruns (from /diagnostics; target 1.00, 0 overruns),
  CPU of the node process (/proc/<pid>/stat utime + stime; target < 50 % of one core),
  p99 jitter of the joint_states period seen by the subscriber (target < 1 ms).
As fast as possible (real_time_factor 0, no subscriber): the node's real-time factor next
to the headless baseline measured in this process (Simulation.advance alone, one publish
period of 20 steps per call, and with the sampler + message building of the node).

    .venv/bin/python benchmarks/bench_simulator_node.py [--duration 60] [--fast-duration 10]
"""

import argparse
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState

from abb_ros.io.wire import cdr
from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.dynamics.spindle import SpindleMotor
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuModel
from abb_ros.model.sensors.sampling import PlantSampler
from abb_ros.testing.procstat import cpu_seconds

ROOT = Path(__file__).resolve().parents[1]

N_BALLS = 10
RATE_HZ = int(round(1.0 / DEFAULT_DT))
STEPS_PER_MS = RATE_HZ // 1000


def start_node(ns: str, *params: str) -> subprocess.Popen:
    args = [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args', '-r',
            f'__ns:={ns}', '-p', f'drive.n:={N_BALLS}']
    for p in params:
        args += ['-p', p]
    return subprocess.Popen(args, cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def stop_node(proc: subprocess.Popen) -> int:
    proc.send_signal(signal.SIGINT)
    try:
        return proc.wait(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.wait()


class Probe:
    """Subscriber in this process: joint_states arrival times and the latest diagnostics."""

    def __init__(self, ns: str, subscribe_states: bool):
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.node = Node('bench_probe', context=self.ctx)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.arrivals = []
        self.diag = None
        self.name = f'{ns}/abb_simulator: simulation'
        if subscribe_states:
            self.node.create_subscription(
                JointState, f'{ns}/joint_states',
                lambda _m: self.arrivals.append(time.perf_counter()), QoSProfile(depth=1000),
                raw=True)
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, 10)

    def _on_diag(self, msg):
        for s in msg.status:
            if s.name == self.name:
                self.diag = (time.perf_counter(), {kv.key: kv.value for kv in s.values})

    def spin_for(self, seconds: float):
        end = time.perf_counter() + seconds
        while time.perf_counter() < end:
            self.executor.spin_once(timeout_sec=0.01)

    def wait_diag(self, deadline_s: float = 90.0):
        end = time.perf_counter() + deadline_s
        while self.diag is None and time.perf_counter() < end:
            self.executor.spin_once(timeout_sec=0.05)
        if self.diag is None:
            raise SystemExit('no /diagnostics from the simulator')

    def close(self):
        self.node.destroy_node()
        rclpy.shutdown(context=self.ctx)


def measure_node(ns: str, seconds: float, rtf: float, subscribe: bool):
    proc = start_node(ns, f'real_time_factor:={rtf}')
    probe = Probe(ns, subscribe)
    try:
        probe.wait_diag()
        probe.spin_for(2.0)  # start-up transients (DDS matching, first ticks)
        d0_t, d0 = probe.diag
        c0, w0 = cpu_seconds(proc.pid), time.perf_counter()
        a0 = len(probe.arrivals)
        probe.spin_for(seconds)
        c1, w1 = cpu_seconds(proc.pid), time.perf_counter()
        d1_t, d1 = probe.diag
        arrivals = np.array(probe.arrivals[a0:])
    finally:
        rc = stop_node(proc)
        probe.close()
    sim_dt = float(d1['sim_time']) - float(d0['sim_time'])
    out = dict(rtf=sim_dt / (d1_t - d0_t), overruns=int(d1['overruns']) - int(d0['overruns']),
               slips=int(d1['slips']) - int(d0['slips']), cpu=(c1 - c0) / (w1 - w0),
               window=w1 - w0, exit_code=rc)
    if subscribe and len(arrivals) > 2:
        period = np.diff(arrivals)
        out.update(received=len(arrivals), rate=(len(arrivals) - 1) / (arrivals[-1] - arrivals[0]),
                   jitter_p99=float(np.percentile(np.abs(period - 1e-3), 99)),
                   jitter_max=float(np.max(np.abs(period - 1e-3))))
    return out


def headless(seconds: float, with_messages: bool) -> float:
    """Real-time factor of the model alone: Simulation.advance in publish periods (1 ms at the
    default step), optionally with the node's sampler (IMU) and CDR encoding."""
    p = DriveParams(n=N_BALLS)
    sim = Simulation(p, 2.7 * p.omega0, DEFAULT_DT, spindle=SpindleMotor(2000.0, 0.05))
    imu = ImuModel(TYPICAL_IMU)
    sampler = PlantSampler(sim, imu, STEPS_PER_MS, STEPS_PER_MS)
    sampler.next_period()  # compile
    wall0 = time.perf_counter()
    sim0 = sim.t
    while time.perf_counter() - wall0 < seconds:
        for _ in range(100):
            if with_messages:
                for sample in sampler.next_period():
                    cdr.sample_cdr(sample, int(DEFAULT_DT * 1e9), imu.config, 0, True)
            else:
                sim.advance(STEPS_PER_MS)
    return (sim.t - sim0) / (time.perf_counter() - wall0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--duration', type=float, default=60.0, help='real-time window [s]')
    ap.add_argument('--fast-duration', type=float, default=10.0, help='fast window [s]')
    args = ap.parse_args()
    print(f'simulator node benchmark: n = {N_BALLS}, {RATE_HZ // 1000} kHz RK4, 1 kHz publish, '
          f'load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores')

    rt = measure_node('/bench_rt', args.duration, 1.0, subscribe=True)
    print(f'\n[real time, {rt["window"]:.0f} s window, subscriber in another process]')
    print(f'  achieved real-time factor  {rt["rtf"]:.4f}   (target 1.00)')
    print(f'  overruns                   {rt["overruns"]} late periods, {rt["slips"]} slips '
          f'(target 0)')
    print(f'  CPU of the node process    {100 * rt["cpu"]:.1f} % of one core (target < 50 %)')
    if 'jitter_p99' in rt:
        print(f'  joint_states received      {rt["received"]} at {rt["rate"]:.1f} Hz')
        print(f'  publish-period jitter      p99 {1e3 * rt["jitter_p99"]:.3f} ms, max '
              f'{1e3 * rt["jitter_max"]:.3f} ms (target p99 < 1 ms)')
    print(f'  exit code after SIGINT     {rt["exit_code"]}')

    fast = measure_node('/bench_fast', args.fast_duration, 0.0, subscribe=False)
    base = headless(min(args.fast_duration, 5.0), with_messages=False)
    base_msgs = headless(min(args.fast_duration, 5.0), with_messages=True)
    print(f'\n[as fast as possible, {fast["window"]:.0f} s window, no subscriber]')
    print(f'  node real-time factor                       {fast["rtf"]:.2f}')
    print(f'  headless Simulation.advance ({STEPS_PER_MS} steps/call) {base:.2f}')
    print(f'  headless + sampler + CDR bytes (no DDS)     {base_msgs:.2f}')
    print(f'  node / headless advance                     {fast["rtf"] / base:.3f}')
    print(f'  CPU of the node process                     {100 * fast["cpu"]:.1f} %')


if __name__ == '__main__':
    main()

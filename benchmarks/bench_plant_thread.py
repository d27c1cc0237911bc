"""The simulator's plant paced by its own thread against the executor's timer (prints figures).

The Table 1 drive (n = 2) at 10 kHz steps, 1 kHz publish, real_time_factor 1, every node in its
own process, each setting with ``ABB_ROS_PACING=timer`` (the rclpy timer in the executor, the
old path) and ``thread`` (the plant's own thread, the default), one after the other:

- **alone**: the simulator with no reader of its 1 kHz topics;
- **recording + analysis**: the simulator recording in process (``record.start``, with the
  analysis' topics in ``record.topics``, as ``bench.launch.py record:=true`` runs it) and the
  analysis node. The old path's analysis reads ``joint_states`` at 1 kHz (remapped:
  ``-r joint_states_throttle:=joint_states``), the new one ``joint_states_throttle`` (50 Hz);
- **subscriber**: the simulator and a subscriber of ``joint_states`` in this process
  (reliable, depth 1000, its messages taken every 2 ms with their message info,
  :class:`abb_ros.nodes.ros.taps.Taps`): the publish-period jitter it sees, |interval - 1 ms|
  between the writer's source timestamps (when the simulator published) and between the
  reception timestamps (when the middleware of this process received them: delivery
  included, the reader's Python scheduling not), and stamps missing (lost); once more with
  the plant's thread under SCHED_FIFO (``realtime_priority`` 50) where the system allows it.

The floor: a Python thread in this process that only sleeps to absolute deadlines 1 ms apart
(what waking up at 1 kHz costs on this machine, with no work), and the plant's own work per
period in this process (``SimulatorNode._integrate_period`` of a paused node, thread CPU),
back to back (warm caches) and after a 1 ms sleep each (cold, as on the plant's thread), with
the period integrated and read in two compiled calls (the default) and step by step, in
alternate turns (medians of eight).

For each: CPU of each process (/proc utime + stime over the window, % of one core), the
simulator's overruns and slips over the window (/diagnostics), and for the recording the
joint_states of the window missing from the bag (gaps in its 1 ms stamps; a slip's dropped
periods count too, never having been published). Load average beside each row.

    .venv/bin/python benchmarks/bench_plant_thread.py [--duration 20]
"""

from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

import numpy as np  # noqa: E402
import rclpy  # noqa: E402
from bench_simulator_node import stop_node  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.qos import QoSProfile  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from abb_ros.io.bag.reader import iter_raw  # noqa: E402
from abb_ros.nodes.ros.entry_point import make_executor  # noqa: E402
from abb_ros.nodes.ros.taps import Taps  # noqa: E402
from abb_ros.testing.procstat import cpu_seconds  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PERIOD_NS = 1_000_000
SETTLE_S = 3.0
PACINGS = ('timer', 'thread')
FIFO_PRIORITY = 50
OTHER_TOPICS = "['stability/margin', '/diagnostics', 'spindle/speed_cmd', 'spindle/current_cmd']"


def start(module: str, pacing: str, ns: str, *ros_args: str) -> subprocess.Popen:
    env = dict(os.environ, ABB_ROS_PACING=pacing)
    return subprocess.Popen([sys.executable, '-m', f'abb_ros.nodes.{module}', '--ros-args',
                             '-r', f'__ns:={ns}', *ros_args], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


class Probe:
    """This process's node: the simulator's status, the analysis' margin, optionally the
    joint_states arrival times and stamps."""

    def __init__(self, ns: str, states: bool):
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.node = Node('bench_probe', context=self.ctx)
        self.status, self.margins, self.taken = None, 0, []
        self.name = f'{ns}/abb_simulator: simulation'
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, 10)
        self.node.create_subscription(Float64, f'{ns}/stability/margin', self._on_margin, 10)
        self.executor = make_executor(self.ctx)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._spin, daemon=True)]
        if states:
            self._taps = Taps(self.node)
            self._states = self._taps.subscribe(JointState, f'{ns}/joint_states',
                                                QoSProfile(depth=1000))
            self._threads.append(threading.Thread(target=self._take, daemon=True))
        for thread in self._threads:
            thread.start()

    def _spin(self):
        while not self._stop.is_set() and self.ctx.ok():
            self.executor.spin_once(timeout_sec=0.05)

    def _on_diag(self, msg):
        for s in msg.status:
            if s.name == self.name:
                self.status = {kv.key: kv.value for kv in s.values}

    def _on_margin(self, _msg):
        self.margins += 1

    def _take(self):
        """(source timestamp, reception timestamp, header stamp) of every joint_states [ns]."""
        while not self._stop.is_set():
            while (taken := Taps.take(self._states)) is not None:
                data, info = taken
                self.taken.append((info['source_timestamp'], info['received_timestamp'],
                                   stamp_of(data)))
            time.sleep(0.002)

    def wait(self, predicate, what: str, timeout_s: float = 120.0):
        end = time.monotonic() + timeout_s
        while not predicate():
            if time.monotonic() > end:
                raise SystemExit(f'timed out after {timeout_s} s waiting for {what}')
            time.sleep(0.05)

    def close(self):
        self._stop.set()
        for thread in self._threads:
            thread.join(10)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.ctx)


def stamp_of(data: bytes) -> int:
    """Header stamp of a stamped message's CDR bytes [ns]."""
    return (int.from_bytes(data[4:8], 'little') * 1_000_000_000
            + int.from_bytes(data[8:12], 'little'))


def jitter(times_ns) -> np.ndarray:
    """|interval - 1 ms| between consecutive times [s]."""
    return np.abs(np.diff(np.asarray(times_ns, dtype=np.int64)) - PERIOD_NS) * 1e-9


def lost(stamps) -> int:
    """Stamps missing from a 1 ms sequence (gaps of k ms lose k - 1)."""
    gaps = np.diff(np.asarray(stamps, dtype=np.int64))
    return int(np.sum(np.maximum(gaps // PERIOD_NS - 1, 0)))


def measure(setting: str, pacing: str, seconds: float, work: Path, priority: int = 0) -> dict:
    """Run one setting with one pacing (and SCHED_FIFO ``priority``); return its figures."""
    ns = f'/bench_{setting}_{pacing}_{priority}'
    sim_args = ['-p', f'realtime_priority:={priority}']
    bag = work / f'{setting}_{pacing}'
    if setting == 'recording':
        sim_args += ['-p', 'record.start:=true', '-p', f'record.path:={bag}',
                     '-p', f'record.topics:={OTHER_TOPICS}']
    procs = {'simulator': start('simulator', pacing, ns, *sim_args)}
    if setting == 'recording':
        remap = ['-r', 'joint_states_throttle:=joint_states'] if pacing == 'timer' else []
        procs['analysis'] = start('analysis', pacing, ns, *remap)
    probe = Probe(ns, states=setting == 'subscriber')
    try:
        probe.wait(lambda: probe.status is not None, 'the simulator status')
        if 'analysis' in procs:
            probe.wait(lambda: probe.margins > 0, 'the first stability/margin')
        time.sleep(SETTLE_S)
        before = {name: cpu_seconds(p.pid) for name, p in procs.items()}
        status0, taken0, w0 = dict(probe.status), len(probe.taken), time.perf_counter()
        wall0 = time.time_ns()
        time.sleep(seconds)
        after = {name: cpu_seconds(p.pid) for name, p in procs.items()}
        status1, w1, wall1 = dict(probe.status), time.perf_counter(), time.time_ns()
        taken = list(probe.taken[taken0:])
    finally:
        codes = {name: stop_node(p) for name, p in procs.items()}
        probe.close()
    out = dict(cpu={name: (after[name] - before[name]) / (w1 - w0) for name in procs},
               scheduling=status1.get('scheduling', '?'),
               overruns=int(status1['overruns']) - int(status0['overruns']),
               slips=int(status1['slips']) - int(status0['slips']), codes=codes,
               load=os.getloadavg()[0])
    if setting == 'subscriber' and len(taken) > 2:
        source, received, stamps = zip(*taken)
        out.update(received=len(taken), lost=lost(stamps), source=jitter(source),
                   reception=jitter(received))
    if setting == 'recording':
        name = f'{ns}/joint_states'
        in_bag = [stamp_of(data) for _, _, data, _ in iter_raw(bag, [name])]
        in_window = [t for t in in_bag if wall0 <= t <= wall1]   # wall-clock stamps
        out.update(recorded=len(in_window), lost=lost(in_window))
    return out


def wake_floor(seconds: float) -> float:
    """CPU of a thread that wakes at absolute deadlines 1 ms apart and does nothing [share]."""
    def loop():
        deadline = time.monotonic_ns()
        end = deadline + int(seconds * 1e9)
        while deadline < end:
            deadline += PERIOD_NS
            time.sleep(max(0.0, (deadline - time.monotonic_ns()) * 1e-9))
    thread = threading.Thread(target=loop)
    cpu0, wall0 = time.thread_time(), time.perf_counter()
    start = time.process_time()
    thread.start()
    thread.join()
    return (time.process_time() - start - (time.thread_time() - cpu0)) / (
        time.perf_counter() - wall0)


def _step_by_step(sampler):
    """``sampler``'s period stepped with ``Simulation.advance``, then read by ``sample_now``."""
    def next_period():
        sampler.sim.advance(sampler.publish_every - sampler.sim.steps % sampler.publish_every)
        sample = sampler.sample_now()
        return [] if sample is None else [sample]
    return next_period


def period_work_us(turns: int = 8, warm: int = 3000, cold: int = 1000
                   ) -> dict[tuple[bool, str], float]:
    """One publish period's work in a paused node in this process [us of thread CPU].

    {(fused, 'warm' | 'cold'): median over the turns}: the period integrated and read in two
    compiled calls (``PlantSampler.next_period``, where the IMU is read at every state sample)
    or step by step (``Simulation.advance``, then ``PlantSampler.sample_now``); warm: ``warm``
    periods back to back; cold: ``cold`` periods each after a 1 ms sleep, as on the plant's
    thread. The two ways take ``turns`` turns each, alternately (which goes first
    alternates too): a single turn moves by tens of percent with the host.
    """
    from rclpy.parameter import Parameter

    from abb_ros.nodes.simulator.node import SimulatorNode
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = SimulatorNode(context=ctx, parameter_overrides=[Parameter('start_paused', value=True)])
    spent = {(fused, kind): [] for fused in (True, False) for kind in ('warm', 'cold')}
    try:
        for turn in range(turns):
            for fused in (turn % 2 == 0, turn % 2 == 1):
                if fused:
                    vars(node.sampler).pop('next_period', None)
                else:
                    node.sampler.next_period = _step_by_step(node.sampler)
                for _ in range(300):
                    node._integrate_period()
                start = time.thread_time()
                for _ in range(warm):
                    node._integrate_period()
                spent[fused, 'warm'].append((time.thread_time() - start) / warm)
                total = 0.0
                for _ in range(cold):
                    time.sleep(PERIOD_NS * 1e-9)
                    start = time.thread_time()
                    node._integrate_period()
                    total += time.thread_time() - start
                spent[fused, 'cold'].append(total / cold)
        return {key: float(np.median(values)) * 1e6 for key, values in spent.items()}
    finally:
        node.destroy_node()
        rclpy.shutdown(context=ctx)


def row(label: str, old: dict, new: dict) -> None:
    cpu_old, cpu_new = sum(old['cpu'].values()), sum(new['cpu'].values())
    parts = ' + '.join(f'{100 * v:.1f}' for v in new['cpu'].values())
    parts_old = ' + '.join(f'{100 * v:.1f}' for v in old['cpu'].values())
    print(f'  {label:24s} {100 * cpu_old:6.1f} % ({parts_old})  {100 * cpu_new:6.1f} % '
          f'({parts})  x {cpu_new / cpu_old:.2f}   load {old["load"]:.2f} / {new["load"]:.2f}')
    print(f'  {"":24s} overruns {old["overruns"]}, slips {old["slips"]}, lost '
          f'{old.get("lost", "-")}  |  overruns {new["overruns"]}, slips {new["slips"]}, '
          f'lost {new.get("lost", "-")}   exit codes {old["codes"]} / {new["codes"]}')


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--duration', type=float, default=20.0, help='measured window [s]')
    args = ap.parse_args()
    print(f'plant thread benchmark: Table 1 drive (n = 2), 10 kHz steps, 1 kHz publish, '
          f'{args.duration:g} s windows, load average {os.getloadavg()[0]:.2f} on '
          f'{os.cpu_count()} cores')
    with tempfile.TemporaryDirectory(prefix='abb_bench_plant_') as tmp:
        results = {(setting, pacing): measure(setting, pacing, args.duration, Path(tmp))
                   for setting in ('alone', 'recording', 'subscriber') for pacing in PACINGS}
        results['subscriber', 'fifo'] = measure('subscriber', 'thread', args.duration,
                                                Path(tmp), priority=FIFO_PRIORITY)
    print('\n  CPU, % of one core        old: executor timer        new: plant thread       '
          'new/old')
    row('simulator alone', results['alone', 'timer'], results['alone', 'thread'])
    row('sim (recording) + analysis', results['recording', 'timer'],
        results['recording', 'thread'])
    print(f'  {"":24s} joint_states of the window in the bag: '
          f'{results["recording", "timer"]["recorded"]} / '
          f'{results["recording", "thread"]["recorded"]}')
    row('sim + 1 kHz subscriber', results['subscriber', 'timer'],
        results['subscriber', 'thread'])
    print('\n  publish-period jitter seen by the subscriber, |interval - 1 ms| [ms]: between the '
          'source timestamps (publish) / reception timestamps (delivered)')
    for pacing in (*PACINGS, 'fifo'):
        r = results['subscriber', pacing]
        label = f'thread, {r["scheduling"]}' if pacing == 'fifo' else pacing
        print(f'  {label}: {r["received"]} received, {r["lost"]} lost, {r["overruns"]} '
              f'overruns, {r["slips"]} slips, CPU {100 * r["cpu"]["simulator"]:.1f} %')
        for kind in ('source', 'reception'):
            j = r[kind] * 1e3
            print(f'    {kind:9s} p50 {np.percentile(j, 50):.3f}  p99 {np.percentile(j, 99):.3f}'
                  f'  max {j.max():.3f}')
    print('  targets: simulator alone <= 10 %, sim (recording) + analysis <= 18 %, p99 < 0.5 ms')
    floor, work = wake_floor(5.0), period_work_us()
    print(f'\n  floor: a thread waking at 1 kHz doing nothing {100 * floor:.1f} % of a core; '
          f'load {os.getloadavg()[0]:.2f}')
    print('  one period of the plant\'s work [us of thread CPU, median of 8 alternate turns]'
          '   warm    cold (1 ms sleep before)')
    for fused, label in ((False, 'step by step'), (True, 'two compiled calls (default)')):
        print(f'    {label:76s} {work[fused, "warm"]:6.1f}  {work[fused, "cold"]:6.1f}')
    print(f'    two calls / step by step {"":52s} x {work[True, "warm"] / work[False, "warm"]:.2f}'
          f'  x {work[True, "cold"] / work[False, "cold"]:.2f}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

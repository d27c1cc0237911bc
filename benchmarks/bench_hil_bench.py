"""The whole HIL bench under load (prints figures; asserts nothing).

Separate processes, as a user runs them: the simulator (n = 10, 10 kHz steps, 1 kHz publish,
real_time_factor 1), the analysis node, the recorder of every topic, and one external
subscriber of ``joint_states`` (a typed rclpy subscription, depth 10, as a user's controller
would have; this script in ``--role subscriber``), optionally a CPU hog pinned to one core
(``--hog``) and the options below. After
``--duration`` seconds (from the first joint_states received) every process is stopped with
SIGINT, simulator first, and this prints: the real-time factor achieved (simulator
diagnostics, since start and over the last window), the largest stamp lag (simulator's own
measure, and receive time - stamp at the subscriber), messages published / received /
recorded / lost per topic, CPU per process (/proc/<pid>/stat utime + stime over the measured
window, in % of one core), RSS growth per minute (least squares over samples every 5 s), and
each process's exit code and whether its output holds 'Traceback' or 'FATAL'. The nodes'
last statuses are read from the recorded bag (no extra /diagnostics subscription: the
measurement adds nothing to the bench).

``--record-in-process`` makes the simulator record every topic of the bench itself
(``record.path`` with ``record.topics`` = the other nodes' topics), ``--no-recorder-node``
leaves the separate recorder out (the statuses then come from the in-process bag), and
``--floor`` measures the middleware floor: the simulator replaced by a process that only
republishes one real sample's CDR bytes on its topics every period (docs/time_under_load.md,
'The middleware floor').

    .venv/bin/python benchmarks/bench_hil_bench.py [--duration 60] [--hog] [--record-in-process]
        [--no-recorder-node] [--floor] [--realtime-priority 50]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

import numpy as np  # noqa: E402
import yaml  # noqa: E402

from abb_ros.io.wire.topics import TOPICS, by_name  # noqa: E402
from abb_ros.testing.procstat import cpu_seconds, rss_bytes  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

N_BALLS = 10
PUBLISH_PERIOD_NS = 1_000_000
RSS_SAMPLE_S = 5.0
SETTLE_S = 2.0
OTHER_TOPICS = tuple(t.name for t in TOPICS if set(t.publishers) != {'simulator'})
"""The bench's topics that other nodes publish: the in-process recording takes them from the
middleware (record.topics), so that its bag holds every topic of the bench."""
STATUS_SIM = 'abb_simulator: simulation'
STATUS_ANALYSIS = 'abb_analysis: stability'
STATUS_RECORDER = 'abb_recorder: recording'


# ---- the external subscriber (its own process) ---------------------------------------------

def run_subscriber(out: Path) -> int:
    """Count joint_states (gaps in the 1 ms stamps = missed) and their lag behind the wall
    clock; write JSON to ``out`` on SIGINT. (The nodes' statuses are read from the recorded
    bag afterwards, so that the measurement adds no subscription to the bench.)"""
    from rclpy.node import Node
    from sensor_msgs.msg import JointState

    from abb_ros.nodes.ros.entry_point import run_node

    class Subscriber(Node):
        def __init__(self):
            super().__init__('bench_subscriber')
            self.stats = dict(received=0, missed=0, max_gap_ms=0.0, max_lag_ms=-math.inf,
                              first_stamp=None, last_stamp=None)
            self.create_subscription(JointState, 'joint_states', self.on_joint_states, 10)

        def on_joint_states(self, msg):
            s = self.stats
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            lag_ms = (time.time_ns() - stamp) * 1e-6
            if s['first_stamp'] is None:
                s['first_stamp'] = stamp
                (out.parent / (out.name + '.ready')).write_text('1')
            else:
                gap = stamp - s['last_stamp']
                s['missed'] += max(0, gap // PUBLISH_PERIOD_NS - 1)
                s['max_gap_ms'] = max(s['max_gap_ms'], gap * 1e-6)
            s['max_lag_ms'] = max(s['max_lag_ms'], lag_ms)
            s['last_stamp'] = stamp
            s['received'] += 1

        def close(self):
            out.write_text(json.dumps(self.stats))

    return run_node('bench_subscriber', Subscriber)


# ---- the middleware floor (its own process, in place of the simulator) -------------------

def run_floor(record: Path | None) -> int:
    """The simulator's publishing without its work: the CDR bytes of one real sample of the
    bench's plant (n = 10, sampled as the node does) published on the simulator's topics with
    its QoS every publish period from a 1 kHz timer (the EventsExecutor, as the node spins),
    and written to an in-process bag when ``record`` is given, as the node records. What the
    bench costs when integration, sampling and encoding cost nothing."""
    from rclpy.node import Node

    from abb_ros.io.bag.writer import BagWriter
    from abb_ros.io.wire import cdr, ros_messages
    from abb_ros.model.dynamics.integrate import Simulation
    from abb_ros.model.parameters.params import DriveParams
    from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuModel
    from abb_ros.model.sensors.sampling import PlantSampler
    from abb_ros.model.sensors.speed_sensor import SpeedSensor
    from abb_ros.nodes.ros.entry_point import run_node
    from abb_ros.nodes.simulator.node import PUBLISH_DEPTH

    params = DriveParams().replace(n=N_BALLS)
    sim = Simulation(params, params.omega0 * 1.5, 1e-4)
    sampler = PlantSampler(sim, ImuModel(TYPICAL_IMU, 0), 10, 10, speed=SpeedSensor(None, 0))
    samples = []
    while not samples:
        samples = sampler.next_period()
    _, encoded = cdr.sample_cdr(samples[-1], 100_000, TYPICAL_IMU)

    class Floor(Node):
        def __init__(self):
            super().__init__('bench_floor')
            self.pubs = [(pub.topic_name, pub, data) for pub, data in (
                (self.create_publisher(ros_messages.TOPIC_TYPES[topic], topic, PUBLISH_DEPTH),
                 data) for topic, data in encoded)]
            self.bag = None
            if record is not None:
                self.bag = BagWriter(record)
                for (topic, _), (name, _, _) in zip(encoded, self.pubs):
                    self.bag.add_topic(name, by_name(topic).type)
            self.create_timer(PUBLISH_PERIOD_NS * 1e-9, self.tick)

        def tick(self):
            now = time.time_ns()
            for name, pub, data in self.pubs:
                pub.publish(data)
                if self.bag is not None:
                    self.bag.write(name, data, now)

        def close(self):
            if self.bag is not None:
                self.bag.close()

    return run_node('bench_floor', Floor)


# ---- the bench ------------------------------------------------------------------------------

def start(args, log_dir: Path, name: str, affinity=None) -> subprocess.Popen:
    log = open(log_dir / f'{name}.log', 'w')
    return subprocess.Popen(
        args, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
        preexec_fn=(lambda: os.sched_setaffinity(0, affinity)) if affinity else None)


def node(module: str, *params: str) -> list[str]:
    cmd = [sys.executable, '-m', f'abb_ros.nodes.{module}', '--ros-args']
    for p in params:
        cmd += ['-p', p]
    return cmd


def wait_for(path: Path, procs: dict, timeout: float) -> float:
    start_t = time.monotonic()
    while not path.exists():
        for name, p in procs.items():
            if p.poll() is not None:
                raise SystemExit(f'{name} exited with {p.returncode} before the bench started')
        if time.monotonic() - start_t > timeout:
            raise SystemExit(f'no joint_states at the subscriber after {timeout} s')
        time.sleep(0.05)
    return time.monotonic() - start_t


def rss_slope_mb_per_min(samples) -> float:
    t = np.array([s[0] for s in samples])
    r = np.array([s[1] for s in samples]) / 2**20
    if len(t) < 2 or t[-1] - t[0] <= 0:
        return math.nan
    return float(np.polyfit(t / 60.0, r, 1)[0])


def bag_counts(bag: Path) -> tuple[dict, dict]:
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    counts = {t['topic_metadata']['name']: t['message_count']
              for t in meta['topics_with_message_count']}
    return counts, meta.get('custom_data') or {}


def bag_statuses(bag: Path) -> dict:
    """{status name: {level, message, values}}: the last /diagnostics status of each node
    in the bag."""
    from abb_ros.io.bag.reader import read_bag
    statuses = {}
    for _, msg, _ in read_bag(bag, ['/diagnostics']):
        for status in msg.status:
            statuses[status.name.lstrip('/')] = dict(
                level=int(status.level[0]), message=status.message,
                values={kv.key: kv.value for kv in status.values})
    return statuses


def arguments() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--duration', type=float, default=60.0, help='measured seconds [60]')
    ap.add_argument('--hog', action='store_true', help='a busy loop pinned to CPU 0')
    ap.add_argument('--record-in-process', action='store_true',
                    help="also record in the simulator (parameter record.path)")
    ap.add_argument('--realtime-priority', type=int, default=0,
                    help="the simulator's realtime_priority (SCHED_FIFO; 0 = normal) [0]")
    ap.add_argument('--no-recorder-node', action='store_true',
                    help='no separate recorder node (with --record-in-process: the plant '
                         'records itself)')
    ap.add_argument('--floor', action='store_true',
                    help="the middleware floor: in place of the simulator, a process that "
                         "publishes one real sample's CDR bytes on its topics every period "
                         "(no integration, sampling or encoding)")
    ap.add_argument('--role', choices=['bench', 'subscriber', 'floor'], default='bench')
    ap.add_argument('--out', type=Path, help=argparse.SUPPRESS)
    return ap


def main() -> int:
    args = arguments().parse_args()
    if args.role == 'subscriber':
        return run_subscriber(args.out)
    if args.role == 'floor':
        return run_floor(args.out)
    work = Path(tempfile.mkdtemp(prefix='abb_bench_'))
    sub_out = work / 'subscriber.json'
    procs, hogs = {}, []
    try:
        if args.hog:
            hogs.append(start([sys.executable, '-c', 'while True: pass'], work, 'hog', {0}))
        start_bench(args, work, sub_out, procs)
        first = wait_for(work / 'subscriber.json.ready', procs, 300.0)
        print(f'first joint_states at the subscriber {first:.2f} s after the simulator started')
        time.sleep(SETTLE_S)
        cpu, rss, wall = measure(procs, args.duration)
    finally:
        codes = stop_bench(procs)
        for hog in hogs:
            hog.kill()
            hog.wait()
    report(args, work, sub_out, cpu, rss, codes, wall)
    return 0


def simulator_params(args, work: Path) -> list[str]:
    """The simulator's -p values: n = N_BALLS at 10 kHz, with the options' extras."""
    params = [f'drive.n:={N_BALLS}', 'integration_rate_hz:=10000', 'publish_rate_hz:=1000']
    if args.realtime_priority:
        params.append(f'realtime_priority:={args.realtime_priority}')
    if args.record_in_process:
        params += [f'record.path:={work / "inproc_bag"}',
                   f'record.topics:=[{", ".join(OTHER_TOPICS)}]']
    return params


def start_bench(args, work: Path, sub_out: Path, procs: dict) -> None:
    """Start the bench's processes into ``procs`` (by name), the plant last."""
    procs['subscriber'] = start([sys.executable, __file__, '--role', 'subscriber',
                                 '--out', str(sub_out)], work, 'subscriber')
    if not args.no_recorder_node:
        procs['recorder'] = start(node('recorder', f'output:={work / "bag"}'), work,
                                  'recorder')
    procs['analysis'] = start(node('analysis'), work, 'analysis')
    if args.floor:
        floor = [sys.executable, __file__, '--role', 'floor']
        if args.record_in_process:
            floor += ['--out', str(work / 'inproc_bag')]
        procs['simulator'] = start(floor, work, 'simulator')
    else:
        procs['simulator'] = start(node('simulator', *simulator_params(args, work)), work,
                                   'simulator')


def measure(procs: dict, duration: float) -> tuple[dict, dict, float]:
    """Return CPU per process (share of one core), RSS samples per process, the wall time."""
    t0 = time.monotonic()
    cpu0 = {name: cpu_seconds(p.pid) for name, p in procs.items()}
    rss = {name: [] for name in procs}
    while time.monotonic() - t0 < duration:
        now = time.monotonic() - t0
        for name, p in procs.items():
            rss[name].append((now, rss_bytes(p.pid)))
        time.sleep(min(RSS_SAMPLE_S, max(0.0, duration - now)))
    wall = time.monotonic() - t0
    cpu = {name: (cpu_seconds(p.pid) - cpu0[name]) / wall for name, p in procs.items()}
    for name, p in procs.items():
        rss[name].append((wall, rss_bytes(p.pid)))
    return cpu, rss, wall


def stop_bench(procs: dict) -> dict:
    """Stop every process with SIGINT, simulator first; return their exit codes by name."""
    codes = {}
    for name in ('simulator', 'analysis', 'recorder', 'subscriber'):
        p = procs.get(name)
        if p is None:
            continue
        time.sleep(0.5 if name == 'analysis' else 0.0)
        p.send_signal(signal.SIGINT)
        try:
            codes[name] = p.wait(timeout=60)
        except subprocess.TimeoutExpired:
            p.kill()
            codes[name] = f'killed (no exit 60 s after SIGINT: {p.wait()})'
    return codes


def report(args, work, sub_out, cpu, rss, codes, wall) -> None:
    sub = json.loads(sub_out.read_text())
    bag = work / ('inproc_bag' if args.no_recorder_node else 'bag')
    statuses = bag_statuses(bag) if bag.exists() else {}
    sim = statuses.get(STATUS_SIM, {}).get('values', {})
    rec = statuses.get(STATUS_RECORDER, {})
    ana = statuses.get(STATUS_ANALYSIS, {})
    counts, custom = bag_counts(bag) if bag.exists() else ({}, {})
    lost = json.loads(custom.get('abb_ros.lost_messages', '{}'))
    plant = ('FLOOR (one sample\'s bytes republished, no physics)' if args.floor
             else f'n = {N_BALLS}, 10 kHz steps')
    recording = ', '.join((['recorder node'] if not args.no_recorder_node else [])
                          + (['in-process'] if args.record_in_process else [])) or 'none'
    print(f'bench: {plant}, 1 kHz publish, real_time_factor 1, recording: {recording}, '
          f'{wall:.1f} s measured, hog on CPU 0: {"yes" if args.hog else "no"}, '
          f'simulator scheduling: {sim.get("scheduling")}, '
          f'{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at the end')
    print(f'real_time_factor achieved: since start {sim.get("real_time_factor_since_start")}, '
          f'last window {sim.get("real_time_factor")}; slips {sim.get("slips")} '
          f'({sim.get("slipped_time")} s dropped), overruns {sim.get("overruns")}')
    if args.floor:
        print('max stamp lag: n/a (the floor republishes one sample, one stamp)')
    else:
        print(f'max stamp lag: simulator (publish time - stamp) {sim.get("stamp_lag_max")} s; '
              f'subscriber (receive time - stamp) {sub["max_lag_ms"]:.3f} ms')
    print(f'{"topic":<22}{"published*":>12}{"received":>10}{"recorded":>10}{"lost(seq)":>10}')
    for topic in ('joint_states', 'deck/pose', 'deck/twist', 'deck/imu', '/diagnostics',
                  'stability/margin'):
        name = topic if topic.startswith('/') else '/' + topic
        received = sub['received'] if topic == 'joint_states' else ''
        print(f'{topic:<22}{sim.get("published " + topic, ""):>12}{received!s:>10}'
              f'{counts.get(name, 0):>10}{lost.get(name, "n/a")!s:>10}')
    print('  * published by the simulator, at its last diagnostics before the stop (<= 1 s '
          'early); /diagnostics and stability/margin are also published by the other nodes')
    dropped = round(float(sim.get('slipped_time', 0.0)) * 1e9 / PUBLISH_PERIOD_NS)
    print(f'subscriber: joint_states received {sub["received"]}, missing stamps '
          f'{sub["missed"]} (of which {dropped} periods dropped by the simulator\'s slips, '
          f'never published: about {sub["missed"] - dropped} lost in delivery), largest gap '
          f'{sub["max_gap_ms"]:.1f} ms')
    print(f'recorder status: level {rec.get("level")} "{rec.get("message")}"')
    print(f'analysis status: level {ana.get("level")} "{ana.get("message", "")[:100]}"')
    if args.record_in_process:
        inproc, _ = bag_counts(work / 'inproc_bag')
        print(f'in-process recording: {inproc}')
    total = sum(cpu.values())
    for name in cpu:
        print(f'CPU {name:<11}{100 * cpu[name]:6.1f} % of one core   RSS '
              f'{rss[name][-1][1] / 2**20:7.1f} MB, growth '
              f'{rss_slope_mb_per_min(rss[name]):+.2f} MB/min')
    print(f'CPU total   {100 * total:6.1f} % of one core (target < 100 %)')
    for name, code in codes.items():
        text = (work / f'{name}.log').read_text(errors='replace')
        bad = [w for w in ('Traceback', 'FATAL') if w in text]
        print(f'{name}: exit {code}' + (f', output has {" and ".join(bad)}' if bad else ''))
    print(f'logs and bags in {work}')


if __name__ == '__main__':
    sys.exit(main())

"""Start-up of the installed nodes (prints figures; asserts nothing).

The fast start: after set-up (kernels compiled and cached), the first ``joint_states``
arrives within 3 s of starting the simulator and the analysis node's first verdict within 5 s,
with a STALE status saying why before it. This starts each node's console script (what
``ros2 run abb_ros <node>`` executes) from the virtual environment, alone, ``--repeat`` times,
with a listener already running in this process, and prints for every start: the time from
the spawn to the first ``joint_states`` at the listener (simulator) or to the first
``stability/margin`` (analysis), the CPU the process had used by then and its exit code
after SIGINT; then the median and maximum. (That the analysis publishes a STALE status until
its first verdict is tested in test/nodes/analysis/test_analysis_first_verdict.py; a
listener that has just
discovered the node may miss it.)
The analysis is started beside a simulator that is already running (its verdict needs the
plant's speed), as a user adds it to a running bench. Between starts the listener waits until
the stopped node's messages are drained; a ``joint_states`` stamped before the spawn is not
counted. The load average is printed: on a busy machine the figures grow with it.

    .venv/bin/python benchmarks/bench_startup.py [--repeat 5]
    .venv/bin/python benchmarks/bench_startup.py --fresh      # a newcomer's first run

``--fresh``: what a newcomer waits for. Two clones of the committed HEAD in a temporary
directory, each with its own venv, sharing a build cache of their own (``ABB_ROS_CACHE_DIR``,
empty at the start); for each, ``scripts/run`` from nothing to the first ``joint_states``, with
the time of every set-up phase read from its progress lines as they come: the requirements'
install (pip, the baseline: the same run's pip time), the kernels the simulator compiles first,
and the rest of the set-up that ``scripts/run`` leaves to a background process (the other
kernel sets, each timed, and the simulation_interfaces build: uncached in the first clone,
from the cache in the second). Then a second start of the first clone (warm).
"""

from __future__ import annotations

import argparse
import os
import random
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from abb_ros.testing.procstat import cpu_seconds  # noqa: E402

BIN = Path(sys.executable).parent
TIMEOUT_S = 60.0
TARGETS_S = {'simulator': 3.0, 'analysis': 5.0}


class Listener(Node):
    """Arrival times (monotonic) of the first message of interest since :meth:`arm`."""

    def __init__(self):
        super().__init__('bench_startup_listener')
        best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
        self.create_subscription(JointState, 'joint_states', self._on_joint_states,
                                 best_effort)
        self.create_subscription(Float64, 'stability/margin', self._on_verdict, best_effort)
        self.last = {'joint_states': 0.0, 'verdict': 0.0}
        self.arm()

    def arm(self) -> None:
        self.first: dict[str, float] = {}
        self.since_ns = time.time_ns()

    def _on_joint_states(self, msg) -> None:
        self.last['joint_states'] = time.monotonic()
        if msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec >= self.since_ns:
            self.first.setdefault('joint_states', time.monotonic())

    def _on_verdict(self, _msg) -> None:
        self.last['verdict'] = time.monotonic()
        self.first.setdefault('verdict', time.monotonic())


def spin_until_quiet(executor, listener, key: str, quiet_s: float = 1.0) -> None:
    """Spin until no ``key`` message arrived for ``quiet_s`` (the last node's are drained)."""
    while time.monotonic() - listener.last[key] < quiet_s:
        executor.spin_once(timeout_sec=0.05)


def spin_for(executor, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)


def start_once(executor, listener, node: str, wanted: str) -> dict:
    spin_until_quiet(executor, listener, wanted)
    listener.arm()
    t0 = time.monotonic()
    proc = subprocess.Popen([str(BIN / node)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
    cpu = None
    while wanted not in listener.first and time.monotonic() - t0 < TIMEOUT_S:
        if proc.poll() is not None:
            break
        executor.spin_once(timeout_sec=0.01)
    if wanted in listener.first and proc.poll() is None:
        cpu = cpu_seconds(proc.pid)
    proc.send_signal(signal.SIGINT)
    try:
        code = proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        code = proc.wait()
    first = listener.first
    seconds = first[wanted] - t0 if wanted in first else float('nan')
    return dict(seconds=seconds, cpu=cpu, exit=code)


ROOT = Path(__file__).resolve().parents[1]
FRESH_TIMEOUT_S = 900.0
PHASES = {'requirements': 'installing requirements.txt', 'package': 'installing abb_ros from',
          'kernels': 'compiling the kernels of', 'interfaces cached': 'from the build cache',
          'background': 'finishing in the background'}
IFACE_LINE = re.compile(r'simulation_interfaces (built|installed from the build cache)\S* '
                        r'(?:\S+ )?in (\d+) s')
SET_LINE = re.compile(r'abb_ros: (\w+) kernels compiled or loaded in ([0-9.]+) s')


class Lines:
    """The lines of a stream with their arrival (monotonic), read by a thread."""

    def __init__(self, stream):
        self.lines: list[tuple[float, str]] = []
        self._thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._thread.start()

    def _read(self, stream) -> None:
        for line in stream:
            self.lines.append((time.monotonic(), line.rstrip()))

    def first(self, text: str) -> float | None:
        return next((t for t, line in self.lines if text in line), None)


def fresh_start(executor, listener, clone: Path, env: dict) -> dict:
    """Run ``scripts/run`` in ``clone``; time the phases and the first joint_states; SIGINT."""
    listener.arm()
    t0 = time.monotonic()
    proc = subprocess.Popen([str(clone / 'scripts' / 'run')], cwd=clone, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            stdin=subprocess.DEVNULL)
    lines = Lines(proc.stderr)
    while 'joint_states' not in listener.first and time.monotonic() - t0 < FRESH_TIMEOUT_S:
        if proc.poll() is not None:
            break
        executor.spin_once(timeout_sec=0.05)
    first = listener.first.get('joint_states')
    proc.send_signal(signal.SIGINT)
    try:
        code = proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        code = proc.wait()
    found = {name: lines.first(text) for name, text in PHASES.items()}
    result = {'first': None if first is None else first - t0, 'exit': code,
              'lines': [line for _, line in lines.lines]}
    for name, at in found.items():
        result[name] = None if at is None else at - t0
    return result


def wait_for_background(clone: Path) -> float:
    """Wait until no set-up of ``clone`` runs any more; return the seconds waited."""
    start = time.monotonic()
    script = str(clone / 'scripts' / 'ensure-venv')
    while (subprocess.run(['pgrep', '-f', script], capture_output=True).returncode == 0
           and time.monotonic() - start < FRESH_TIMEOUT_S):
        time.sleep(0.5)
    return time.monotonic() - start


def fresh(executor, listener) -> int:
    """Print the newcomer's figures of two fresh clones (module docstring, ``--fresh``)."""
    head = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=ROOT, text=True,
                          capture_output=True, check=True).stdout.strip()
    print(f'fresh clones of {head}, {os.cpu_count()} CPUs, load average '
          f'{os.getloadavg()[0]:.2f} at the start')
    with tempfile.TemporaryDirectory(prefix='abb_fresh_') as tmp:
        env = dict(os.environ, ABB_ROS_CACHE_DIR=str(Path(tmp) / 'cache'))
        env.pop('VIRTUAL_ENV', None)
        for k in range(2):
            clone = Path(tmp) / f'clone{k + 1}'
            subprocess.run(['git', 'clone', '-q', str(ROOT), str(clone)], check=True)
            r = fresh_start(executor, listener, clone, env)
            describe_fresh(f'clone {k + 1}, first start', r)
            waited = wait_for_background(clone)
            log = (clone / '.venv' / 'setup-background.log')
            text = log.read_text() if log.is_file() else ''
            sets = ', '.join(f'{m[1]} {float(m[2]):.1f} s' for m in SET_LINE.finditer(text))
            print(f'  background set-up done {waited:.1f} s after the first start ended'
                  f' (kernel sets, each in its process: {sets or "none"})')
            iface = IFACE_LINE.search(text) or IFACE_LINE.search('\n'.join(r['lines']))
            print('  simulation_interfaces: ' + (f'{iface[1]} in {iface[2]} s' if iface
                                                 else 'not built (no cmake or compiler?)'))
            if k == 0:
                r2 = fresh_start(executor, listener, clone, env)
                describe_fresh('clone 1, second start', r2)
    print(f'load average {os.getloadavg()[0]:.2f} at the end')
    return 0


def describe_fresh(what: str, r: dict) -> None:
    def at(key):
        return 'n/a' if r[key] is None else f'{r[key]:.1f} s'
    pip = (None if r['requirements'] is None or r['package'] is None
           else r['package'] - r['requirements'])
    after_pip = (None if r['first'] is None or r['package'] is None
                 else r['first'] - r['package'])
    print(f'{what}: first joint_states {at("first")} after scripts/run (exit {r["exit"]})')
    if r['first'] is None:
        print('  its set-up said:\n    ' + '\n    '.join(r['lines'][-20:]))
    if pip is not None:
        print(f'  pip install of the requirements {pip:.1f} s (baseline); first joint_states '
              f'{after_pip:.1f} s after it ({after_pip / pip:.2f} x the pip time)')
    if all(r[key] is None for key in PHASES):
        return
    print(f'  phases from the start: requirements {at("requirements")}, package '
          f'{at("package")}, simulator kernels {at("kernels")}, background handed over '
          f'{at("background")}')


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--repeat', type=int, default=5, help='starts per node [5]')
    ap.add_argument('--fresh', action='store_true',
                    help="a newcomer's first run: two fresh clones (minutes)")
    args = ap.parse_args()
    for node in TARGETS_S:
        if not (BIN / node).exists():
            print(f'{BIN / node} not found: install the package into this venv first '
                  '(scripts/ensure-venv)', file=sys.stderr)
            return 2
    rclpy.init()
    listener = Listener()
    executor = SingleThreadedExecutor()
    executor.add_node(listener)
    spin_for(executor, 1.0)
    if args.fresh:
        code = fresh(executor, listener)
        executor.shutdown()
        listener.destroy_node()
        rclpy.shutdown()
        return code
    print(f'start-up of the console scripts in {BIN}, {os.cpu_count()} CPUs, '
          f'load average {os.getloadavg()[0]:.2f} at the start')
    plant = None
    for node, wanted in (('simulator', 'joint_states'), ('analysis', 'verdict')):
        if node == 'analysis':
            plant = subprocess.Popen([str(BIN / 'simulator')], stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
            spin_for(executor, 5.0)
        runs = [start_once(executor, listener, node, wanted) for _ in range(args.repeat)]
        for i, r in enumerate(runs, 1):
            cpu = 'n/a' if r['cpu'] is None else f"{r['cpu']:.2f} s"
            print(f'  {node:9s} #{i}: first {wanted} after {r["seconds"]:.2f} s '
                  f'(CPU used {cpu}), exit {r["exit"]}')
        times = [r['seconds'] for r in runs]
        print(f'{node}: first {wanted} median {statistics.median(times):.2f} s, '
              f'max {max(times):.2f} s (target {TARGETS_S[node]:.0f} s)')
    print(f'load average {os.getloadavg()[0]:.2f} at the end')
    plant.send_signal(signal.SIGINT)
    plant.wait(timeout=20)
    executor.shutdown()
    listener.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())

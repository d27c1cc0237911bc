"""The simulator recording in process plus the analysis node, this tree against a revision.

The Table 1 drive (n = 2) at 10 kHz steps, 1 kHz publish, real time, the plant on its own
thread, as the "sim (recording) + analysis" row of benchmarks/bench_plant_thread.py runs it:
the simulator recording in process (``record.start``, the analysis' topics in
``record.topics``) and the analysis node, each in its own process. The nodes run once from
this checkout and once from ``--against`` (a git revision exported with ``git archive`` into a
temporary directory, its kernels compiled there first by ``python -m abb_ros.model.warmup``),
alternately (each first in every other round), ``--rounds`` times, so that both see the same
load.

For each run: the CPU of each thread over the window (/proc/<pid>/task/*/stat utime + stime,
% of one core) grouped as the simulator's plant thread (``abb_plant``), its executor (the
main thread: services, timers, the drain of ``record.topics``) and its other threads
(middleware), the analysis node's main thread (executor) and its other threads; the
simulator's overruns over the window (/diagnostics); the joint_states of the window missing
from the bag. Then the median of each column over the rounds and its ratio, this checkout
over the revision, and the load average beside every row.

The plant thread's share moves by several points from run to run, more than the recording
costs it; so last, in one process per tree, the write path alone (``--write-path``): the
simulator's own messages of a bag just recorded, period by period, given to
``Recording.write`` by a thread that sleeps to absolute deadlines 1 ms apart (as the plant's
thread does), and ``Recording.drain`` every 50 periods (the executor's timer): the CPU time
of each per period (``time.thread_time``, its own cost subtracted), best of three runs.

    .venv/bin/python benchmarks/bench_recording_analysis.py --against main [--rounds 3]
"""

from __future__ import annotations

import argparse
import io
import json
import os
import random
import statistics
import subprocess
import sys
import tarfile
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

from bench_plant_thread import OTHER_TOPICS, SETTLE_S, Probe, lost, stamp_of  # noqa: E402
from bench_simulator_node import stop_node  # noqa: E402

from abb_ros.io.bag.reader import iter_raw  # noqa: E402
from abb_ros.testing.procstat import CLK_TCK  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PLANT_THREAD = 'abb_plant'
COLUMNS = ('plant', 'executor', 'sim other', 'analysis', 'an. other')


def export(revision: str, into: Path) -> tuple[Path, str]:
    """Export ``revision`` of this repository into ``into`` and compile its kernels there.

    Returns the tree and the revision's short hash.
    """
    short = subprocess.run(['git', '-C', str(ROOT), 'rev-parse', '--short', revision],
                           check=True, capture_output=True, text=True).stdout.strip()
    tar = subprocess.run(['git', '-C', str(ROOT), 'archive', '--format=tar', revision],
                         check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(tar)) as archive:
        archive.extractall(into, filter='data')
    start = time.perf_counter()
    subprocess.run([sys.executable, '-m', 'abb_ros.model.warmup'], cwd=into, check=True,
                   env=dict(os.environ, PYTHONPATH=str(into)), stdout=subprocess.DEVNULL)
    print(f'  {revision} ({short}) exported, kernels compiled in '
          f'{time.perf_counter() - start:.0f} s', flush=True)
    return into, short


def start(tree: Path, module: str, ns: str, *ros_args: str) -> subprocess.Popen:
    """Start the node ``module`` of ``tree`` in namespace ``ns``."""
    env = dict(os.environ, PYTHONPATH=str(tree), ABB_ROS_PACING='thread')
    return subprocess.Popen([sys.executable, '-m', f'abb_ros.nodes.{module}', '--ros-args',
                             '-r', f'__ns:={ns}', *ros_args], cwd=tree, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def thread_cpu(pid: int) -> dict[tuple[int, str], float]:
    """Return {(thread id, name): user + system CPU [s]} of the threads of process ``pid``."""
    out = {}
    for task in Path(f'/proc/{pid}/task').iterdir():
        try:
            name = (task / 'comm').read_text().strip()
            fields = (task / 'stat').read_text().rsplit(')', 1)[1].split()
        except OSError:   # the thread ended
            continue
        out[int(task.name), name] = (int(fields[11]) + int(fields[12])) / CLK_TCK
    return out


def grouped(pid: int, before: dict, after: dict, wall_s: float) -> tuple[float, float, float]:
    """Return the CPU shares (plant thread, main thread, the others) over the window."""
    plant = main = other = 0.0
    for key, cpu in after.items():
        used = (cpu - before.get(key, 0.0)) / wall_s
        if key[1] == PLANT_THREAD:
            plant += used
        elif key[0] == pid:
            main += used
        else:
            other += used
    return plant, main, other


def measure(tree: Path, seconds: float, work: Path, tag: str) -> dict:
    """Run the simulator (recording) and the analysis from ``tree``; return the figures."""
    ns = f'/bench_rec_{tag}_{os.getpid()}'
    bag = work / f'bag_{tag}'
    procs = {'simulator': start(tree, 'simulator', ns, '-p', 'record.start:=true',
                                '-p', f'record.path:={bag}', '-p',
                                f'record.topics:={OTHER_TOPICS}'),
             'analysis': start(tree, 'analysis', ns)}
    probe = Probe(ns, states=False)
    try:
        probe.wait(lambda: probe.status is not None, 'the simulator status')
        probe.wait(lambda: probe.margins > 0, 'the first stability/margin')
        time.sleep(SETTLE_S)
        before = {name: thread_cpu(p.pid) for name, p in procs.items()}
        status0, w0, wall0 = dict(probe.status), time.perf_counter(), time.time_ns()
        time.sleep(seconds)
        after = {name: thread_cpu(p.pid) for name, p in procs.items()}
        status1, wall_s, wall1 = dict(probe.status), time.perf_counter() - w0, time.time_ns()
    finally:
        codes = {name: stop_node(p) for name, p in procs.items()}
        probe.close()
    sim = grouped(procs['simulator'].pid, before['simulator'], after['simulator'], wall_s)
    _, analysis, helpers = grouped(procs['analysis'].pid, before['analysis'],
                                   after['analysis'], wall_s)
    in_bag = [stamp_of(data) for _, _, data, _ in iter_raw(bag, [f'{ns}/joint_states'])]
    in_window = [t for t in in_bag if wall0 <= t <= wall1]   # wall-clock stamps
    return dict(cpu=(*sim, analysis, helpers), bag=bag,
                overruns=int(status1['overruns']) - int(status0['overruns']),
                recorded=len(in_window), lost=lost(in_window), codes=codes,
                load=os.getloadavg()[0])


def write_path(bag: Path, runs: int = 3) -> dict:
    """CPU per period [us] of Recording.write on a 1 kHz thread and of the drain (best of runs).

    Run in a process of the tree measured (PYTHONPATH): the Recording of that tree.
    """
    import rclpy
    from rclpy.node import Node
    from rclpy.qos import QoSProfile

    from abb_ros.io.bag.writer import BagWriter
    from abb_ros.nodes.recorder.recording import Recording
    graph = tuple('/' + t.strip(" '") for t in OTHER_TOPICS.strip('[]').split(','))
    by_stamp: dict[int, list] = {}
    for topic, type_name, data, log_time in iter_raw(bag):
        if not topic.endswith(graph):
            by_stamp.setdefault(log_time, []).append((topic, type_name, data, log_time))
    periods = [by_stamp[t] for t in sorted(by_stamp)][:5000]
    qos = QoSProfile(depth=1000)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = Node('bench_write_path', context=ctx)
    clock = time.thread_time_ns
    best: dict[str, int] = {}
    out_dir = Path(tempfile.mkdtemp(prefix='abb_write_path_', dir=bag.parent))
    for run in range(runs):
        recording = Recording(node, BagWriter(out_dir / str(run)))
        out = {'plant': 0, 'drain': 0}

        def loop():
            calibration = clock() - clock()   # minus one pair of clock calls
            deadline = time.monotonic_ns()
            for i, period in enumerate(periods):
                start = clock()
                for topic, type_name, data, log_time in period:
                    recording.write(topic, type_name, qos, data, log_time)
                out['plant'] += clock() - start + calibration
                if i % 50 == 49:
                    start = clock()
                    recording.drain()
                    out['drain'] += clock() - start + calibration
                deadline += 1_000_000
                time.sleep(max(0.0, (deadline - time.monotonic_ns()) * 1e-9))
            start = clock()
            recording.finish()
            out['drain'] += clock() - start + calibration
        thread = threading.Thread(target=loop)
        thread.start()
        thread.join()
        for key, ns in out.items():
            best[key] = min(best.get(key, ns), ns)
    node.destroy_node()
    rclpy.shutdown(context=ctx)
    return dict(periods=len(periods), messages=sum(len(p) for p in periods),
                plant=best['plant'] / len(periods) / 1e3,
                drain=best['drain'] / len(periods) / 1e3)


def write_path_of(tree: Path, bag: Path) -> dict:
    """Run :func:`write_path` in a process of ``tree``."""
    done = subprocess.run([sys.executable, __file__, '--write-path', str(bag)], cwd=tree,
                          env=dict(os.environ, PYTHONPATH=str(tree)), check=True,
                          capture_output=True, text=True)
    return json.loads(done.stdout.splitlines()[-1])


def line(label: str, cpu, tail: str) -> None:
    cells = ''.join(f'{100 * c:10.1f}' for c in cpu)
    print(f'  {label:22s}{cells}{100 * sum(cpu):9.1f}   {tail}', flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--against', default='main', help='git revision compared with this tree')
    ap.add_argument('--duration', type=float, default=20.0, help='measured window [s]')
    ap.add_argument('--rounds', type=int, default=3, help='runs of each tree, alternately')
    ap.add_argument('--write-path', type=Path, help=argparse.SUPPRESS)   # write_path_of's
    args = ap.parse_args()
    if args.write_path is not None:
        print(json.dumps(write_path(args.write_path)))
        return 0
    print(f'simulator (recording in process) + analysis: this tree against {args.against}; '
          f'Table 1 drive (n = 2), 10 kHz steps, 1 kHz publish, {args.duration:g} s windows, '
          f'{args.rounds} rounds; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} '
          f'cores', flush=True)
    with tempfile.TemporaryDirectory(prefix='abb_bench_rec_') as tmp:
        other, short = export(args.against, Path(tmp) / 'against')
        trees = {short: other, 'this tree': ROOT}
        print(f'\n  CPU, % of one core     {"":4s}' + ''.join(f'{c:>10s}' for c in COLUMNS)
              + f'{"total":>9s}', flush=True)
        runs = {label: [] for label in trees}
        for n in range(args.rounds):
            order = list(trees.items())
            for label, tree in order[::-1] if n % 2 else order:   # each first in turn
                r = measure(tree, args.duration, Path(tmp), f'{n}_{int(tree is ROOT)}')
                runs[label].append(r)
                line(f'{n + 1}: {label}', r['cpu'],
                     f'overruns {r["overruns"]}, joint_states in the bag {r["recorded"]} '
                     f'(lost {r["lost"]}), exit {sorted(set(r["codes"].values()))}, '
                     f'load {r["load"]:.2f}')
        bag = runs['this tree'][-1]['bag']   # this tree's messages, given to each tree's writer
        paths = {label: write_path_of(tree, bag) for label, tree in trees.items()}
    medians = {label: [statistics.median(r['cpu'][i] for r in rs)
                       for i in range(len(COLUMNS))] for label, rs in runs.items()}
    print()
    for label, med in medians.items():
        line(f'median: {label}', med, '')
    old, new = medians[short], medians['this tree']
    ratios = ''.join(f'{n / o:10.2f}' if o > 0 else f'{"-":>10s}' for n, o in zip(new, old))
    print(f'  {"this tree / " + short:22s}{ratios}{sum(new) / sum(old):9.2f}   load '
          f'{os.getloadavg()[0]:.2f}')
    print('  target (on a quiet machine): simulator (recording) + analysis <= 18 % of a core')
    print(f'\n  write path alone, CPU per 1 ms period [us] (best of 3 runs): Recording.write on '
          f'the 1 kHz thread, the drain every 50 periods; load {os.getloadavg()[0]:.2f}')
    for label, figures in paths.items():
        print(f'  {label:22s}write {figures["plant"]:7.2f}   drain {figures["drain"]:7.2f}   '
              f'total {figures["plant"] + figures["drain"]:7.2f}   ({figures["messages"]} '
              f'messages in {figures["periods"]} periods)')
    old, new = paths[short], paths['this tree']
    print(f'  {"this tree / " + short:22s}write {new["plant"] / old["plant"]:7.2f}   total '
          f'{(new["plant"] + new["drain"]) / (old["plant"] + old["drain"]):13.2f}   load '
          f'{os.getloadavg()[0]:.2f}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

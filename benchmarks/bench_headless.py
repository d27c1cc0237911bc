"""Speed of the headless run with a bag: prints figures, asserts nothing.

``abb-sim run --scenario p3_n10`` (n = 10) for DURATION simulated seconds, 10 kHz RK4, every
sampled topic at its rate, in this process:
  1. without a bag (the compiled loop samples the state only): the baseline;
  2. ``abb-sim run --out`` (messages encoded by abb_ros.io.wire.cdr, MCAP writing and closing
     included): wall time, real-time factor, messages/s, ratio to the baseline;
  3. the same loop with a bag that drops the messages: the share of the writing;
and the cost per message of each part: sampling a batch of periods, its CDR encoding, the
live node's per-sample contents and encoding (against rclpy's serialize_message of the same
messages, the reference), BagWriter.write.

    .venv/bin/python benchmarks/bench_headless.py [--duration 10] [--scenario p3_n10]
"""

import argparse
import contextlib
import dataclasses
import io
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

from rclpy.serialization import deserialize_message, serialize_message

from abb_ros import cli
from abb_ros.app.headless import PUBLISH_DT, STATE_TOPIC_TYPES, run_scenario
from abb_ros.io.bag.writer import BagWriter
from abb_ros.io.files.scenario import load_scenario
from abb_ros.io.wire import cdr, ros_messages
from abb_ros.io.wire.msgdefs import message_class
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuModel
from abb_ros.model.sensors.sampling import PlantSampler
from abb_ros.model.sensors.speed_sensor import SpeedSensor

ROOT = Path(__file__).resolve().parents[1]

DT_NS = int(round(DEFAULT_DT * 1e9))
EVERY = int(round(PUBLISH_DT / DEFAULT_DT))


def cli_run(scenario: str, duration: float, out: Path | None) -> tuple[float, dict]:
    """``abb-sim run`` in this process: (wall time of the whole command [s], summary)."""
    argv = ['run', '--scenario', scenario, '--duration', str(duration), '--json',
            '--no-progress'] + (['--out', str(out)] if out else [])
    stdout = io.StringIO()
    wall0 = time.perf_counter()
    with contextlib.redirect_stdout(stdout):
        code = cli.main(argv)
    wall = time.perf_counter() - wall0
    if code:
        sys.exit(f'abb-sim {" ".join(argv)} failed with exit code {code}')
    return wall, json.loads(stdout.getvalue())


class _DroppingBag:
    """A bag for run_scenario that drops the messages: the run less the writing."""

    def add_topic(self, *args) -> None:
        """Do nothing."""

    def write_many(self, *args) -> None:
        """Do nothing."""


def sampler_for(scenario) -> PlantSampler:
    p = scenario.params
    y0 = initial_state(p, scenario.omega, phi0=scenario.phi0, deck0=scenario.deck0)
    sim = Simulation(p, scenario.omega, DEFAULT_DT, spindle=scenario.spindle, y0=y0)
    return PlantSampler(sim, ImuModel(TYPICAL_IMU, 0), EVERY, EVERY, speed=SpeedSensor())


def per_message_costs(scenario, periods: int = 2000) -> dict[str, float]:
    """Mean cost per message [us] of each part, on the samples of ``periods`` periods."""
    sampler = sampler_for(scenario)
    sampler.next_periods(1)
    wall0 = time.perf_counter()
    batches = [sampler.next_periods(periods // 2) for _ in range(2)]
    sampling = time.perf_counter() - wall0
    samples = [s for batch in batches for s in batch.samples()]
    count = sum(len(cdr.sample_cdr(s, DT_NS, TYPICAL_IMU, with_clock=True)[1])
                for s in samples)
    costs = {'RK4 steps + IMU + FG (PlantSampler.next_periods)': sampling / count * 1e6}

    def timed(name, fn, repeat=3):
        """Best of ``repeat`` passes (the first one also warms caches up)."""
        best = float('inf')
        for _ in range(repeat):
            wall0 = time.perf_counter()
            result = fn()
            best = min(best, time.perf_counter() - wall0)
        costs[name] = best / count * 1e6
        return result

    timed('CDR of the batches (abb_ros.io.wire.cdr.batch_cdr)', lambda: [
        cdr.batch_cdr(b, DT_NS, TYPICAL_IMU, with_clock=True) for b in batches])
    timed('per sample, as the live node: contents', lambda: [
        ros_messages.sample_contents(s, DT_NS, TYPICAL_IMU, with_clock=True) for s in samples])
    encoded = timed('per sample: contents + CDR (cdr.sample_cdr)', lambda: [
        cdr.sample_cdr(s, DT_NS, TYPICAL_IMU, with_clock=True) for s in samples])
    messages = [deserialize_message(data, message_class(STATE_TOPIC_TYPES[topic]))
                for _, pairs in encoded for topic, data in pairs]
    timed('serialize_message(rclpy message) (reference)', lambda: [
        serialize_message(m) for m in messages])
    with tempfile.TemporaryDirectory() as tmp, BagWriter(Path(tmp) / 'bag') as bag:
        for topic, type_name in STATE_TOPIC_TYPES.items():
            bag.add_topic(topic, type_name)
        timed('BagWriter.write(bytes) (MCAP, zstd)', lambda: [
            bag.write(topic, data, stamp) for stamp, pairs in encoded for topic, data in pairs],
              repeat=1)
    return costs


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--duration', type=float, default=10.0, help='simulated seconds')
    ap.add_argument('--scenario', default='p3_n10')
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    scenario.duration = args.duration
    print(f'headless abb-sim run: scenario {scenario.name} (n = {scenario.params.n}), '
          f'{args.duration:g} s simulated, {round(1 / DEFAULT_DT)} Hz RK4, '
          f'{len(STATE_TOPIC_TYPES)} topics at {round(1 / PUBLISH_DT)} Hz; load average '
          f'{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores')
    run_scenario(dataclasses.replace(scenario, duration=0.01))  # compile the kernels

    tmp = Path(tempfile.mkdtemp(prefix='bench_headless_'))
    try:
        base_wall, base = cli_run(args.scenario, args.duration, None)
        bag_wall, with_bag = cli_run(args.scenario, args.duration, tmp / 'fast')
        discarded = run_scenario(scenario, bag=_DroppingBag()).wall_time
        size = sum(f.stat().st_size for f in (tmp / 'fast').iterdir())
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    messages = with_bag['messages']
    base_loop = base['wall_time_s']
    print(f'\n  {"":40s} {"loop s":>7} {"RTF":>6} {"msg/s":>8} {"x no bag":>8} '
          f'{"command s":>9} {"RTF":>6}')

    def row(label, loop, command=None, with_messages=True):
        rate = f'{messages / loop:8.0f}' if with_messages else f'{"-":>8}'
        line = (f'  {label:40s} {loop:7.2f} {args.duration / loop:6.2f} {rate} '
                f'{loop / base_loop:8.2f}')
        if command is not None:
            line += f' {command:9.2f} {args.duration / command:6.2f}'
        print(line)

    row('no bag (baseline)', base_loop, base_wall, with_messages=False)
    row('abb-sim run --out (fast CDR encoder)', with_bag['wall_time_s'], bag_wall)
    row('messages encoded, not written', discarded)
    print(f'\n  {messages} messages, bag {size / 1e6:.1f} MB; with the bag the run keeps '
          f'{base_loop / with_bag["wall_time_s"]:.2f} of its speed without')
    print(f'  without the writing it would keep {base_loop / discarded:.2f}: the writer takes '
          f'{(with_bag["wall_time_s"] - discarded) / messages * 1e6:.2f} us per message '
          'of the loop')
    print('  loop: integration + messages + BagWriter.write (RunResult.wall_time); command: '
          'the whole abb-sim run\n  in this process (scenario, bag open/close, summary); '
          'not written: run_scenario with\n  a bag that drops the messages it is given')

    print(f'\n  cost per message [us] (mean over 2000 periods of {scenario.name}; '
          'best of 3 but the first two):')
    for name, us in per_message_costs(scenario).items():
        print(f'    {name:50s} {us:7.2f}')


if __name__ == '__main__':
    main()

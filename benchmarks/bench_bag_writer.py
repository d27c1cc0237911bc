"""Speed of the bag writer next to foxglove-sdk's MCAP sink: prints figures, asserts nothing.

Both write the same N pre-encoded ``sensor_msgs/msg/JointState`` CDR messages (the bytes
:mod:`abb_ros.io.wire.cdr` encodes for simulation samples of ``p3_n10``, n = 10) to an MCAP file
with zstd chunks of the same size, one after the other in this process:
  a. ``abb_ros.io.bag.writer.BagWriter.write``, one call per message;
  b. ``BagWriter.write_many``, one call per batch of a simulation sample's size;
  c. foxglove-sdk's sink: ``foxglove.open_mcap`` with a ``Channel`` of schema encoding
     ``ros2msg`` and message encoding ``cdr``, ``Channel.log`` per message (its default
     options: zstd at the default level, compressed on a pool of threads).
Each time includes opening and closing the file. ``--profile`` adds cProfile's view of a.

    .venv/bin/python benchmarks/bench_bag_writer.py [--messages 200000] [--profile]
"""

import argparse
import cProfile
import datetime
import os
import pstats
import shutil
import tempfile
import time
from pathlib import Path

import foxglove
from foxglove import Channel, Schema
from foxglove.mcap import MCAPWriteOptions

from abb_ros.app.headless import PUBLISH_DT
from abb_ros.io.bag.writer import DEFAULT_CHUNK_SIZE, BagWriter
from abb_ros.io.files.scenario import load_scenario
from abb_ros.io.wire import cdr, msgdefs
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuModel
from abb_ros.model.sensors.sampling import PlantSampler

TOPIC = '/joint_states'
TYPE = 'sensor_msgs/msg/JointState'
DT_NS = int(round(DEFAULT_DT * 1e9))
EVERY = int(round(PUBLISH_DT / DEFAULT_DT))
BATCH = 7   # messages of one simulation sample with /clock


def joint_states(count: int = 20_000) -> list[bytes]:
    """Return the JointState CDR bytes of ``count`` successive samples of p3_n10.

    20,000 messages are 7 MB: a chunk holds no message twice, as in a real bag.
    """
    scenario = load_scenario('p3_n10')
    p = scenario.params
    y0 = initial_state(p, scenario.omega, phi0=scenario.phi0, deck0=scenario.deck0)
    sim = Simulation(p, scenario.omega, DEFAULT_DT, spindle=scenario.spindle, y0=y0)
    sampler = PlantSampler(sim, ImuModel(TYPICAL_IMU, 0), EVERY, EVERY)
    found = []
    while len(found) < count:
        for sample in sampler.next_period():
            _, encoded = cdr.sample_cdr(sample, DT_NS, TYPICAL_IMU, with_clock=True)
            found += [data for topic, data in encoded if '/' + topic.lstrip('/') == TOPIC]
    return found[:count]


def with_bag_writer(path: Path, messages: list[bytes], stamps: list[int]) -> None:
    """Write with ``BagWriter.write``, one call per message."""
    with BagWriter(path) as bag:
        bag.add_topic(TOPIC, TYPE)
        write = bag.write
        for data, stamp in zip(messages, stamps):
            write(TOPIC, data, stamp)


def with_write_many(path: Path, messages: list[bytes], stamps: list[int]) -> None:
    """Write with ``BagWriter.write_many``, one call per BATCH messages."""
    with BagWriter(path) as bag:
        bag.add_topic(TOPIC, TYPE)
        pairs = [(TOPIC, data) for data in messages]
        for i in range(0, len(pairs), BATCH):
            bag.write_many(pairs[i:i + BATCH], stamps[i])


def with_foxglove(path: Path, messages: list[bytes], stamps: list[int]) -> None:
    """Write with foxglove-sdk's MCAP sink, ``Channel.log`` per message."""
    options = MCAPWriteOptions(profile='ros2', chunk_size=DEFAULT_CHUNK_SIZE)
    with foxglove.open_mcap(path, writer_options=options):
        channel = Channel(TOPIC, schema=Schema(name=TYPE, encoding='ros2msg',
                                               data=msgdefs.full_text(TYPE).encode()),
                          message_encoding='cdr',
                          metadata={'topic_type_hash': msgdefs.type_hash(TYPE)})
        log = channel.log
        for data, stamp in zip(messages, stamps):
            log(data, log_time=stamp)
        channel.close()


def timed(fn, directory: Path, messages, stamps) -> tuple[float, float, int]:
    """Return (wall s, CPU s of the process, file size) of the faster of two writes."""
    best, size = (float('inf'), 0.0), 0
    for attempt in range(2):
        target = directory / f'{fn.__name__}_{attempt}'
        path = target / 'bag_0.mcap' if fn is with_foxglove else target
        path.parent.mkdir(parents=True, exist_ok=True)
        wall0, cpu0 = time.perf_counter(), time.process_time()
        fn(path, messages, stamps)
        best = min(best, (time.perf_counter() - wall0, time.process_time() - cpu0))
        size = sum(f.stat().st_size for f in target.rglob('*.mcap'))
        shutil.rmtree(target)
    return best[0], best[1], size


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--messages', type=int, default=200_000)
    ap.add_argument('--profile', action='store_true', help='profile BagWriter.write')
    args = ap.parse_args()
    distinct = joint_states()
    messages = [distinct[i % len(distinct)] for i in range(args.messages)]
    stamps = [1_000_000_000 + 1_000_000 * i for i in range(args.messages)]
    now = datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')
    load = ', '.join(f'{x:.2f}' for x in os.getloadavg())
    print(f'bag writer: {args.messages} JointState messages of {len(messages[0])} bytes '
          f'(p3_n10, n = 10), zstd chunks of {DEFAULT_CHUNK_SIZE // 1024} KiB; {now}, '
          f'{os.cpu_count()} cores, load average {load}')
    directory = Path(tempfile.mkdtemp(prefix='bench_bag_writer_'))
    try:
        results = {}
        for label, fn in (('BagWriter.write', with_bag_writer),
                          (f'BagWriter.write_many ({BATCH} a call)', with_write_many),
                          ('foxglove-sdk 0.30.3 MCAP sink', with_foxglove)):
            results[label] = timed(fn, directory, messages, stamps)
        if args.profile:
            profiler = cProfile.Profile()
            profiler.runcall(with_bag_writer, directory / 'profiled', messages, stamps)
    finally:
        shutil.rmtree(directory, ignore_errors=True)
    sdk = results['foxglove-sdk 0.30.3 MCAP sink'][0]
    print(f'\n  {"":38s} {"us/msg":>7} {"x sdk":>6} {"CPU us":>7} {"MB":>6}')
    for label, (seconds, cpu, size) in results.items():
        print(f'  {label:38s} {seconds / args.messages * 1e6:7.2f} {seconds / sdk:6.2f} '
              f'{cpu / args.messages * 1e6:7.2f} {size / 1e6:6.1f}')
    print('  us/msg: wall time, the faster of two runs, opening and closing the file included;'
          '\n  x sdk: over the sink\'s; CPU us: CPU time of the process (all its threads)')
    print(f'  load average after: {", ".join(f"{x:.2f}" for x in os.getloadavg())}')
    if args.profile:
        print('\nBagWriter.write, cProfile (tottime):')
        pstats.Stats(profiler).sort_stats('tottime').print_stats(12)


if __name__ == '__main__':
    main()

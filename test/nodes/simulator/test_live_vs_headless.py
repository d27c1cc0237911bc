"""A live simulator node and a headless run of the same scenario give the same messages.

The node runs as a subprocess at real_time_factor 0 (it owns time: stamps start at 0 and it
publishes /clock) with scenario P3's parameters passed exactly (repr of the floats), the
default IMU settings and seed; this test records its topics over DDS (raw CDR bytes, a
private Context, reliable keep-all). ``abb_ros.app.headless.run_scenario`` writes the same
scenario to a bag with the fast encoder (abb_ros.io.wire.cdr). For every topic, the messages with
the same header stamp must be byte-identical: same integrator, same step (1e-4 s both ways),
same sampling schedule, same IMU noise sequence, same message contents. No tolerance: there
is no reason for a difference in the last bit (P3 runs at constant speed; the node's spindle
motor, holding its command, has theta'' = (cmd - omega) / tau = +0.0 exactly, as
ConstantSpeed gives).

The node starts publishing before discovery completes, and at real_time_factor 0 it outruns
any reader (its writers keep the last few messages, as a publisher's history does), so
messages may be missed: the comparison is on what was received, and it must cover a long
unbroken stretch. ``spindle/speed`` (std_msgs/Float64) has no stamp: each message received is
matched to the headless message of the same index by its publication sequence number (the
writer's count, 1 for its first message), so a missed message cannot shift the comparison.
"""

import signal
import struct
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest
import rclpy
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from abb_ros.app.headless import STATE_TOPIC_TYPES, run_scenario
from abb_ros.io.bag.reader import iter_raw
from abb_ros.io.bag.writer import BagWriter
from abb_ros.io.files.scenario import load_scenario
from abb_ros.io.wire import ros_messages
from abb_ros.model.sensors.imu import TYPICAL_IMU
from abb_ros.nodes.ros.taps import Taps

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[3]
PERIOD_NS = 1_000_000            # publish period of the state topics and the IMU (1 kHz)
SPAN_NS = 1_500_000_000          # simulated time recorded after the first message received
MIN_STRETCH = 500                # consecutive common periods required on every topic
DEADLINE_S = 40.0                # generous: the machine is shared; a healthy run takes ~5 s
SEED = 0
RAW_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
IMU_FIELDS = ('accel_noise_density', 'accel_bias', 'accel_bias_random_walk',
              'gyro_noise_density', 'gyro_bias', 'gyro_bias_random_walk')


def node_parameters(scenario) -> list[str]:
    """ROS parameters reproducing the headless run exactly (repr: shortest round-trip text)."""
    p = scenario.params
    values = {f'drive.{name}': repr(value) for name, value in p.as_dict().items()}
    values.update({'spindle.initial_speed': repr(scenario.omega), 'real_time_factor': '0.0',
                   'integration_rate_hz': '10000', 'publish_rate_hz': '1000',
                   'seed': str(SEED), 'imu.rate_hz': str(int(TYPICAL_IMU.rate)),
                   'imu.gravity': str(TYPICAL_IMU.gravity).lower(),
                   'imu.position': '[' + ', '.join(map(repr, TYPICAL_IMU.position)) + ']'})
    values.update({f'imu.{k}': repr(getattr(TYPICAL_IMU, k)) for k in IMU_FIELDS})
    return [arg for k, v in values.items() for arg in ('-p', f'{k}:={v}')]


def stamp_of(data: bytes) -> int:
    """Header stamp (or Clock.clock) [ns]: the first field of every recorded type."""
    sec, nanosec = struct.unpack_from('<iI', data, 4)
    return sec * 1_000_000_000 + nanosec


def record_live(scenario, namespace: str) -> dict[str, list[tuple[bytes, int]]]:
    """Run the node, record its state topics raw until SPAN_NS of simulated time was seen.

    Returns {topic: [(CDR bytes, publication sequence number), ...]} in the order received.
    """
    proc = subprocess.Popen(
        [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args', '-r',
         f'__ns:={namespace}', *node_parameters(scenario)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = Node('live_vs_headless_recorder', context=ctx)
    taps = Taps(node)
    got = {topic: [] for topic in STATE_TOPIC_TYPES}
    try:
        subs = {topic: taps.subscribe(ros_messages.TOPIC_TYPES[topic],
                                      topic if topic.startswith('/') else f'{namespace}/{topic}',
                                      RAW_QOS)
                for topic in STATE_TOPIC_TYPES}
        deadline = time.monotonic() + DEADLINE_S
        states = got['joint_states']
        while not (states and stamp_of(states[-1][0]) - stamp_of(states[0][0]) >= SPAN_NS):
            if time.monotonic() > deadline or proc.poll() is not None:
                proc.kill()
                pytest.fail(f'timed out after {DEADLINE_S} s: {sum(map(len, got.values()))} '
                            'messages; '
                            f'node output:\n{proc.communicate()[0]}')
            taken = 0
            for topic, sub in subs.items():
                while (message := taps.take(sub)) is not None:
                    data, info = message
                    got[topic].append((data, info['publication_sequence_number']))
                    taken += 1
            if not taken:
                time.sleep(0.002)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        taps.destroy()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
    return got


def longest_run(stamps: list[int], step: int) -> int:
    """Longest number of consecutive stamps ``step`` apart."""
    best = run = 1 if stamps else 0
    for a, b in zip(stamps, stamps[1:]):
        run = run + 1 if b - a == step else 1
        best = max(best, run)
    return best


UNSTAMPED = {'spindle/speed'}


def check_unstamped_run(topic: str, live: list[tuple[bytes, int]],
                        headless: list[bytes]) -> None:
    """Each live message of ``topic`` equals the headless message its publication sequence
    number names (the k-th message published is the k-th of the run), and the run is long."""
    sequence = [seq for _, seq in live]
    assert sequence == sorted(set(sequence)), f'{topic}: sequence numbers not increasing'
    assert longest_run(sequence, 1) >= MIN_STRETCH, (
        f'{topic}: only {longest_run(sequence, 1)} consecutive messages recorded')
    assert sequence[-1] <= len(headless), f'{topic}: more messages live than headless'
    differing = [seq for data, seq in live if data != headless[seq - 1]]
    assert not differing, (f'{topic}: {len(differing)} of {len(live)} messages differ from '
                           f'the headless ones of the same index, first the {differing[0]}th')


def test_live_node_and_headless_run_publish_byte_identical_messages(tmp_path):
    scenario = load_scenario('p3')
    live = record_live(scenario, f'/lvh_{uuid.uuid4().hex[:8]}')
    last = max(stamp_of(data) for topic, messages in live.items() if topic not in UNSTAMPED
               for data, _ in messages)
    scenario.duration = (last // PERIOD_NS + 1) * PERIOD_NS * 1e-9
    with BagWriter(tmp_path / 'headless') as bag:
        run_scenario(scenario, imu_config=TYPICAL_IMU, seed=SEED, bag=bag)
    headless = {topic: {} for topic in STATE_TOPIC_TYPES}
    sequences = {topic: [] for topic in UNSTAMPED}
    for topic, _, data, _ in iter_raw(tmp_path / 'headless'):
        topic = topic.lstrip('/') if topic != '/clock' else topic
        if topic in UNSTAMPED:
            sequences[topic].append(data)
        else:
            headless[topic][stamp_of(data)] = data

    for topic in UNSTAMPED:
        check_unstamped_run(topic, live.pop(topic), sequences[topic])
    for topic, received in live.items():
        messages = [data for data, _ in received]
        stamps = [stamp_of(data) for data in messages]
        assert stamps == sorted(set(stamps)), f'{topic}: stamps not strictly increasing'
        missing = [s for s in stamps if s not in headless[topic]]
        assert not missing, f'{topic}: live stamps {missing[:3]} not in the headless run'
        differing = [s for s, data in zip(stamps, messages) if data != headless[topic][s]]
        assert not differing, (f'{topic}: {len(differing)} of {len(stamps)} messages differ, '
                               f'first at t = {differing[0] * 1e-9:.4f} s')
        assert longest_run(stamps, PERIOD_NS) >= MIN_STRETCH, (
            f'{topic}: only {longest_run(stamps, PERIOD_NS)} consecutive periods recorded')

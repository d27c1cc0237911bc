"""Speed of bag writing and of the live recorder (prints figures; asserts nothing).

1. Writer throughput (messages/s), in this process: BagWriter with CDR bytes (the recorder's
   path) and with rclpy messages (the headless run's path) against mcap-ros2-support's plain
   ``mcap_ros2.writer.Writer`` (messages as dicts) and the bare ``mcap`` writer.
2. Recorder: a publisher at RATE Hz on the five state topics for SECONDS, the recorder as a
   subprocess over DDS; the messages recorded against those published.

Run: ``.venv/bin/python benchmarks/bench_recorder.py [--seconds 5] [--rate 1000]``
"""

import argparse
import io
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def joint_state(i):
    from sensor_msgs.msg import JointState
    return JointState(name=['spindle', 'ball_1', 'ball_2'], position=[i * 1e-3, 1.8, -1.8],
                      velocity=[523.6, 0.0, 0.0])


def bench_writers(n):
    from mcap.writer import Writer as McapWriter
    from mcap_ros2.writer import Writer as Ros2Writer
    from rclpy.serialization import serialize_message

    from abb_ros.io.bag.writer import BagWriter
    from abb_ros.io.wire import msgdefs

    msgs = [joint_state(i) for i in range(n)]
    payloads = [serialize_message(m) for m in msgs]
    dicts = [{'header': {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': ''},
              'name': list(m.name), 'position': list(m.position), 'velocity': list(m.velocity),
              'effort': []} for m in msgs]
    type_name = 'sensor_msgs/msg/JointState'
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        def ours(kind, data):
            t0 = time.perf_counter()
            with BagWriter(Path(tmp) / kind) as bag:
                bag.add_topic('joint_states', type_name)
                for i, d in enumerate(data):
                    bag.write('joint_states', d, i)
            results[kind] = n / (time.perf_counter() - t0)

        ours('BagWriter, CDR bytes (recorder)', payloads)

        t0 = time.perf_counter()
        with open(Path(tmp) / 'baseline.mcap', 'wb') as f:
            writer = Ros2Writer(f)
            schema = writer.register_msgdef(type_name, msgdefs.full_text(type_name))
            for i, d in enumerate(dicts):
                writer.write_message('/joint_states', schema, d, log_time=i)
            writer.finish()
        results['mcap_ros2 Writer, dicts (baseline)'] = n / (time.perf_counter() - t0)

        t0 = time.perf_counter()
        writer = McapWriter(io.BytesIO())
        writer.start('ros2', 'bench')
        sid = writer.register_schema(type_name, 'ros2msg', b'')
        cid = writer.register_channel('/joint_states', 'cdr', sid)
        for i, d in enumerate(payloads):
            writer.add_message(cid, log_time=i, data=d, publish_time=i)
        writer.finish()
        results['bare mcap Writer, bytes in memory'] = n / (time.perf_counter() - t0)
    base = results['mcap_ros2 Writer, dicts (baseline)']
    print(f'writer throughput, {n} sensor_msgs/JointState:')
    for name, rate in results.items():
        print(f'  {name:40s} {rate:10.0f} msg/s   x{rate / base:5.2f} of baseline')


def bench_recorder(seconds, rate):
    import rclpy
    from geometry_msgs.msg import PoseStamped, TwistStamped
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from sensor_msgs.msg import Imu, JointState

    from abb_ros.io.bag.reader import iter_raw

    os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    topics = [('joint_states', JointState), ('deck/pose', PoseStamped),
              ('deck/twist', TwistStamped), ('deck/imu', Imu)]
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / 'bag'
        proc = subprocess.Popen([sys.executable, '-m', 'abb_ros.nodes.recorder', '--ros-args',
                                 '-p', f'output:={bag}'], cwd=ROOT,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        ctx = Context()
        rclpy.init(context=ctx)
        node = Node('bench_publisher', context=ctx)
        pubs = [(node.create_publisher(cls, name, 10), cls()) for name, cls in topics]
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        deadline = time.monotonic() + 30
        while any(p.get_subscription_count() == 0 for p, _ in pubs):
            if time.monotonic() > deadline:
                raise SystemExit('the recorder did not subscribe in 30 s')
            time.sleep(0.05)
        sent = [0]

        def tick():
            for pub, msg in pubs:
                pub.publish(msg)
            sent[0] += len(pubs)

        node.create_timer(1.0 / rate, tick)
        t0 = time.monotonic()
        while time.monotonic() - t0 < seconds:
            executor.spin_once(timeout_sec=0.01)
        elapsed = time.monotonic() - t0
        time.sleep(1.0)
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=60)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        recorded = sum(1 for _ in iter_raw(bag))
    print(f'recorder, {len(topics)} topics, timer at {rate} Hz for {elapsed:.1f} s:')
    print(f'  published {sent[0]} ({sent[0] / elapsed:.0f} msg/s achieved by the publisher)')
    print(f'  recorded  {recorded} ({recorded / elapsed:.0f} msg/s), '
          f'dropped {sent[0] - recorded} ({100 * (sent[0] - recorded) / max(sent[0], 1):.2f} %)')


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--messages', type=int, default=20000)
    parser.add_argument('--seconds', type=float, default=5.0)
    parser.add_argument('--rate', type=float, default=1000.0)
    args = parser.parse_args()
    bench_writers(args.messages)
    bench_recorder(args.seconds, args.rate)


if __name__ == '__main__':
    main()

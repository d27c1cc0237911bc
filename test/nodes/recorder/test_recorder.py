"""The `recorder` node over real DDS: what is published on the abb topics ends up in the bag.

The recorder runs as a subprocess (``python -m abb_ros.nodes.recorder``) so that it can be
stopped by signals; the test process publishes through its own rclpy Context.
"""

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from abb_ros.io.bag.reader import is_finished, read_bag
from abb_ros.io.bag.writer import INCOMPLETE_KEY
from abb_ros.io.files.safe_yaml import load_file

pytestmark = pytest.mark.ros
ROOT = Path(__file__).resolve().parents[3]


def start_recorder(output, *params):
    args = [sys.executable, '-m', 'abb_ros.nodes.recorder', '--ros-args',
            '-p', f'output:={output}']
    for p in params:
        args += ['-p', p]
    return subprocess.Popen(args, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)


class Publisher:
    """The test's side of the graph: a private Context and one publisher per topic."""

    def __init__(self, topics):
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node('recorder_test_publisher', context=self.context)
        self.pubs = {name: self.node.create_publisher(cls, name, 10) for name, cls in topics}

    def wait_for_recorder(self, timeout=30.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if all(p.get_subscription_count() > 0 for p in self.pubs.values()):
                return
            time.sleep(0.05)
        raise AssertionError(f'timed out after {timeout} s waiting for the recorder to subscribe '
                             'to every topic')

    def close(self):
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def finish(proc, sig, timeout=30):
    proc.send_signal(sig)
    out, _ = proc.communicate(timeout=timeout)
    return proc.returncode, out


@pytest.mark.slow
@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_recorder_writes_every_published_message_and_finishes_the_bag_on_a_signal(
        tmp_path, sig):
    bag = tmp_path / 'bag'
    proc = start_recorder(bag)
    pub = Publisher([('joint_states', JointState), ('spindle/speed_cmd', Float64),
                     ('stability/margin', Float64)])
    try:
        pub.wait_for_recorder()
        n = 200
        for i in range(n):
            pub.pubs['joint_states'].publish(JointState(
                name=['spindle', 'ball_1', 'ball_2'], position=[float(i), 0.5, -0.5]))
            pub.pubs['spindle/speed_cmd'].publish(Float64(data=100.0 + i))
            pub.pubs['stability/margin'].publish(Float64(data=-float(i)))
            time.sleep(0.002)
        time.sleep(1.0)  # delivery over the loopback is well under a second
    finally:
        pub.close()
        code, out = finish(proc, sig)
    assert code == 0, out
    assert is_finished(bag)
    with AnyReader([bag]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        got = {}
        for conn, _, raw in reader.messages():
            got.setdefault(conn.topic, []).append(reader.deserialize(raw, conn.msgtype))
    assert types == {'/joint_states': 'sensor_msgs/msg/JointState',
                     '/spindle/speed_cmd': 'std_msgs/msg/Float64',
                     '/stability/margin': 'std_msgs/msg/Float64'}
    # Reliable QoS, a publisher queue of 10 and a recorder queue of 1000: nothing is lost.
    assert [m.position[0] for m in got['/joint_states']] == [float(i) for i in range(n)]
    assert list(got['/joint_states'][0].name) == ['spindle', 'ball_1', 'ball_2']
    assert [m.data for m in got['/spindle/speed_cmd']] == [100.0 + i for i in range(n)]
    assert [m.data for m in got['/stability/margin']] == [-float(i) for i in range(n)]


@pytest.mark.slow
def test_a_killed_recorder_loses_at_most_the_last_chunk(tmp_path):
    bag = tmp_path / 'bag'
    chunk = 1024
    proc = start_recorder(bag, f'chunk_size:={chunk}')
    pub = Publisher([('spindle/speed_cmd', Float64)])
    try:
        pub.wait_for_recorder()
        n = 1000
        for i in range(n):
            pub.pubs['spindle/speed_cmd'].publish(Float64(data=float(i)))
            time.sleep(0.001)
        time.sleep(1.0)
        proc.send_signal(signal.SIGKILL)
        proc.communicate(timeout=30)
    finally:
        pub.close()
    assert proc.returncode == -signal.SIGKILL
    assert not is_finished(bag)
    values = [m.data for _, m, _ in read_bag(bag)]
    # A chunk of 1024 bytes holds fewer than 1024 / 12 Float64 messages (12 CDR bytes each
    # plus a 31-byte record header), so at most that many of the n are missing.
    assert values == [float(i) for i in range(len(values))]
    assert n - chunk // 12 <= len(values) <= n


@pytest.fixture
def tiny_disk(tmp_path):
    """A 96 KiB tmpfs (we run as root); skipped where mounting is not allowed."""
    disk = tmp_path / 'disk'
    disk.mkdir()
    mounted = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=96k', 'tmpfs', str(disk)],
                             capture_output=True)
    if mounted.returncode != 0:
        pytest.skip(f'cannot mount a tmpfs here: {mounted.stderr.decode().strip()}')
    try:
        yield disk
    finally:
        subprocess.run(['umount', '-l', str(disk)], check=False)


@pytest.mark.slow
def test_a_full_disk_ends_the_recording_with_an_error_and_a_readable_bag(tiny_disk):
    bag = tiny_disk / 'bag'
    proc = start_recorder(bag, 'chunk_size:=2048', 'compression:=none')
    pub = Publisher([('spindle/speed_cmd', Float64)])
    try:
        pub.wait_for_recorder()
        deadline = time.monotonic() + 60
        i = 0
        while proc.poll() is None and time.monotonic() < deadline:
            pub.pubs['spindle/speed_cmd'].publish(Float64(data=float(i)))
            i += 1
            time.sleep(0.0005)
        out, _ = proc.communicate(timeout=30)
    finally:
        pub.close()
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1, out
    assert 'recording stopped' in out and 'No space left on device' in out
    values = [m.data for _, m, _ in read_bag(bag)]
    # The disk held some thousand messages; all that were written are a gapless prefix.
    assert len(values) > 1000
    assert values == [float(k) for k in range(len(values))]
    # metadata.yaml counts exactly what the file holds (never the messages still in memory
    # when the disk refused the chunk), and says that the bag is incomplete and why.
    info = load_file(bag / 'metadata.yaml')['rosbag2_bagfile_information']
    assert info['message_count'] == len(values)
    assert info['files'][0]['message_count'] == len(values)
    [topic] = info['topics_with_message_count']
    assert topic['message_count'] == len(values)
    assert 'No space left on device' in info['custom_data'][INCOMPLETE_KEY]

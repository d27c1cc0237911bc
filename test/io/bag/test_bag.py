"""rosbag2-compatible MCAP bags: independent readers (rosbags, mcap with CRCs) read what we write.

References: rosbag2 Jazzy ``rosbag2_storage_mcap`` (channel metadata, 'rosbag2' metadata record),
``rosbag2_storage/yaml.hpp`` (metadata v9), ``LocalMessageDefinitionSource`` (schema text).
"""

import errno
import io
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import yaml
from builtin_interfaces.msg import Time
from cdr_reference import cdr_bytes
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped, TwistStamped
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.rosbag2.metadata import parse_qos
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import Float64

from abb_ros.io.bag.reader import is_finished, read_bag, read_drive_params
from abb_ros.io.bag.recovery import recover
from abb_ros.io.bag.writer import BagError, BagWriteError, BagWriter
from abb_ros.io.wire import msgdefs

ROOT = Path(__file__).resolve().parents[3]


def sample_messages():
    """One message of every type the package records, with distinctive values."""
    stamp = Time(sec=12, nanosec=345)
    pose = PoseStamped()
    pose.header.stamp, pose.header.frame_id = stamp, 'base'
    pose.pose.position.x, pose.pose.position.z = 1.5e-4, -2e-5
    pose.pose.orientation.z, pose.pose.orientation.w = 0.1, 0.99498743710662
    twist = TwistStamped()
    twist.header.frame_id = 'deck'
    twist.twist.angular.y = -0.25
    imu = Imu()
    imu.header.frame_id = 'deck'
    imu.orientation_covariance[0] = -1.0
    imu.linear_acceleration.x = 9.81
    imu.angular_velocity_covariance[4] = 1e-6
    diag = DiagnosticArray(status=[DiagnosticStatus(
        level=DiagnosticStatus.WARN, name='abb_simulator: real time', message='overrun',
        hardware_id='abb', values=[KeyValue(key='rtf', value='0.97')])])
    return [
        ('/spindle/speed_cmd', 'std_msgs/msg/Float64', Float64(data=523.6)),
        ('/joint_states', 'sensor_msgs/msg/JointState', JointState(
            name=['spindle', 'ball_1', 'ball_2'], position=[3.0, 1.85, -1.85],
            velocity=[523.6, 0.01, -0.01])),
        ('/deck/pose', 'geometry_msgs/msg/PoseStamped', pose),
        ('/deck/twist', 'geometry_msgs/msg/TwistStamped', twist),
        ('/deck/imu', 'sensor_msgs/msg/Imu', imu),
        ('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray', diag),
        ('/clock', 'rosgraph_msgs/msg/Clock', Clock(clock=stamp)),
    ]


def write_samples(path, repeat=3, **kwargs):
    samples = sample_messages()
    with BagWriter(path, **kwargs) as bag:
        for topic, type_name, _ in samples:
            bag.add_topic(topic, type_name)
        bag.set_drive_params({'R': 0.015, 'n': 2})
        for i in range(repeat):
            for j, (topic, _, msg) in enumerate(samples):
                bag.write(topic, cdr_bytes(msg), 1_000_000_000 + 1000 * i + j)
    return samples


def test_rosbags_reads_every_message_type_back_with_its_type_and_values(tmp_path):
    samples = write_samples(tmp_path / 'bag')
    store = get_typestore(Stores.ROS2_JAZZY)
    with AnyReader([tmp_path / 'bag']) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        digests = {c.topic: c.digest for c in reader.connections}
        got = {}
        for conn, _, raw in reader.messages():
            got.setdefault(conn.topic, []).append(reader.deserialize(raw, conn.msgtype))
    assert types == {topic: type_name for topic, type_name, _ in samples}
    for topic, type_name, _ in samples:
        assert digests[topic] == store.hash_rihs01(type_name)
        assert len(got[topic]) == 3
    # Values exactly as written (binary floats survive CDR unchanged).
    assert got['/spindle/speed_cmd'][0].data == 523.6
    js = got['/joint_states'][2]
    assert list(js.name) == ['spindle', 'ball_1', 'ball_2']
    assert list(js.position) == [3.0, 1.85, -1.85] and list(js.effort) == []
    assert got['/deck/pose'][0].pose.position.x == 1.5e-4
    assert got['/deck/pose'][0].header.stamp.nanosec == 345
    assert got['/deck/twist'][0].twist.angular.y == -0.25
    assert got['/deck/imu'][0].orientation_covariance[0] == -1.0
    status = got['/diagnostics'][0].status[0]
    assert (status.level, status.values[0].value) == (1, '0.97')
    assert got['/clock'][1].clock.sec == 12


def test_our_reader_returns_equal_rclpy_messages_and_the_drive_parameters(tmp_path):
    samples = write_samples(tmp_path / 'bag', repeat=1)
    read = list(read_bag(tmp_path / 'bag'))
    assert [(t, m) for t, m, _ in read] == [(t, m) for t, _, m in samples]
    assert [ts for _, _, ts in read] == [1_000_000_000 + j for j in range(len(samples))]
    assert read_drive_params(tmp_path / 'bag') == {'R': 0.015, 'n': 2}
    assert [t for t, _, _ in read_bag(tmp_path / 'bag', topics=['deck/imu'])] == ['/deck/imu']


def test_mcap_passes_the_mcap_library_validation_and_carries_rosbag2_records(tmp_path):
    samples = write_samples(tmp_path / 'bag', repeat=50, chunk_size=2048)
    mcap_file = tmp_path / 'bag' / 'bag_0.mcap'
    with open(mcap_file, 'rb') as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == 'ros2'
        summary = reader.get_summary()
        assert summary.statistics.message_count == 50 * len(samples)
        assert len(summary.chunk_indexes) > 1
        assert {c.compression for c in summary.chunk_indexes} == {'zstd'}
        assert {s.encoding for s in summary.schemas.values()} == {'ros2msg'}
        for channel in summary.channels.values():
            assert channel.message_encoding == 'cdr'
            qos = parse_qos(channel.metadata['offered_qos_profiles'])
            assert qos[0].reliability.name == 'RELIABLE'
            type_name = summary.schemas[channel.schema_id].name
            assert channel.metadata['topic_type_hash'] == msgdefs.type_hash(type_name)
        # mcap_ros2's own .msg parser decodes every message with our schema texts.
        decoded = list(reader.iter_decoded_messages())
        assert len(decoded) == 50 * len(samples)
        assert decoded[1].decoded_message.name == ['spindle', 'ball_1', 'ball_2']
        records = {m.name: m.metadata for m in reader.iter_metadata()}
    inner = yaml.safe_load(records['rosbag2']['serialized_metadata'])
    outer = yaml.safe_load((tmp_path / 'bag' / 'metadata.yaml').read_text())
    assert outer['rosbag2_bagfile_information'] == inner
    assert inner['version'] == 9 and inner['ros_distro'] == 'jazzy'
    assert inner['storage_identifier'] == 'mcap'
    assert inner['relative_file_paths'] == ['bag_0.mcap']
    assert inner['message_count'] == 50 * len(samples)
    assert inner['duration']['nanoseconds'] == 49 * 1000 + len(samples) - 1


def file_records(path):
    """The records of an MCAP file, chunks decompressed, offsets and compressed sizes left out."""
    import zstandard
    from mcap.records import Chunk, ChunkIndex, Footer, MetadataIndex, SummaryOffset
    from mcap.stream_reader import StreamReader

    found = []
    with open(path, 'rb') as f:
        for record in StreamReader(f, emit_chunks=True).records:
            if isinstance(record, Chunk):
                data = zstandard.decompress(record.data, record.uncompressed_size)
                record = ('chunk', record.message_start_time, record.message_end_time,
                          record.uncompressed_size, record.uncompressed_crc, data)
            elif isinstance(record, ChunkIndex):
                record = ('chunk index', record.message_start_time, record.message_end_time,
                          sorted(record.message_index_offsets), record.message_index_length,
                          record.compression, record.uncompressed_size)
            elif isinstance(record, MetadataIndex):
                record = ('metadata index', record.name, record.length)
            elif isinstance(record, (Footer, SummaryOffset)):
                continue
            found.append(record)
    return found


def _feed(writer, record):
    """Give ``record`` (a schema, channel or message) to mcap's Writer as its call."""
    from mcap.records import Channel, Message, Schema
    if isinstance(record, Schema):
        writer.register_schema(record.name, record.encoding, record.data)
    elif isinstance(record, Channel):
        writer.register_channel(record.topic, record.message_encoding, record.schema_id,
                                record.metadata)
    elif isinstance(record, Message):
        writer.add_message(record.channel_id, record.log_time, record.data,
                           record.publish_time, record.sequence)



def replay_with_mcap_writer(source, target, chunk_size):
    """Write the records of the MCAP file ``source`` again with mcap's own Writer.

    Each chunk's records are fed to the Writer in order and the chunk is then ended
    (``flush``), so the Writer's chunks end where the source's do unless its own size rule
    ends one elsewhere; metadata records are added where they stand.
    """
    from mcap.records import Channel, Chunk, Header, Metadata, Schema
    from mcap.stream_reader import StreamReader, breakup_chunk
    from mcap.writer import CompressionType, Writer

    with open(source, 'rb') as f, open(target, 'wb') as out:
        writer = Writer(out, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        for record in StreamReader(f, emit_chunks=True).records:
            if isinstance(record, Header):
                writer.start(record.profile, record.library)
            elif isinstance(record, Chunk):
                for inner in breakup_chunk(record, validate_crc=True):
                    _feed(writer, inner)
                writer.flush()
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, record.metadata)
            elif isinstance(record, (Schema, Channel)):   # summary repeats: finish writes them
                continue
        writer.finish()


def test_the_bag_holds_the_records_mcaps_own_writer_writes(tmp_path):
    """The bag's MCAP file (written by abb_ros.io.bag.mcap_file, not by mcap's Writer) holds the
    records that mcap's Writer writes for the same calls: the same chunks once decompressed,
    message indexes, metadata, statistics and summary (several chunks, out-of-order log times,
    a topic added mid-chunk, a flush)."""
    path = tmp_path / 'bag'
    with BagWriter(path, chunk_size=2048) as bag:
        samples = sample_messages()
        for topic, type_name, _ in samples[:-1]:
            bag.add_topic(topic, type_name)
        for i in range(200):
            if i == 100:
                bag.add_topic(samples[-1][0], samples[-1][1])
            for j, (topic, _, msg) in enumerate(samples[:-1] if i < 100 else samples):
                bag.write(topic, cdr_bytes(msg), 1_000_000_000 + 1000 * (i ^ 5) + j)
            if i == 150:
                bag.flush()
    replay_with_mcap_writer(path / 'bag_0.mcap', tmp_path / 'mcap.mcap', chunk_size=2048)
    ours, theirs = file_records(path / 'bag_0.mcap'), file_records(tmp_path / 'mcap.mcap')
    assert sum(isinstance(r, tuple) and r[0] == 'chunk' for r in ours) > 10
    assert ours == theirs


def test_write_many_writes_what_write_writes_for_each_message(tmp_path):
    samples = sample_messages()
    files = []
    for many in (True, False):
        path = tmp_path / str(many) / 'bag'
        with BagWriter(path, chunk_size=2048) as bag:
            for topic, type_name, _ in samples:
                bag.add_topic(topic, type_name)
            for i in range(100):
                pairs = [(topic.lstrip('/') if i % 2 else topic, cdr_bytes(msg))
                         for topic, _, msg in samples]
                if many:
                    bag.write_many(pairs, 1_000_000_000 + 1000 * i)
                else:
                    for topic, data in pairs:
                        bag.write(topic, data, 1_000_000_000 + 1000 * i)
        files.append((path / 'bag_0.mcap').read_bytes())
    assert files[0] == files[1]
    with BagWriter(tmp_path / 'bad') as bag, pytest.raises(BagError, match='not added'):
        bag.write_many([('/nowhere', b'')], 0)


def test_schema_text_is_the_msg_file_then_each_dependency_once_after_80_equals():
    text = msgdefs.full_text('sensor_msgs/msg/Imu')
    own = (msgdefs.share_dir('sensor_msgs') / 'msg' / 'Imu.msg').read_text()
    assert text.startswith(own)
    blocks = text[len(own):].split('\n' + '=' * 80 + '\n')
    assert blocks[0] == ''
    names = [b.split('\n', 1)[0] for b in blocks[1:]]
    assert sorted(names) == sorted(set(names)) == [
        'MSG: builtin_interfaces/Time', 'MSG: geometry_msgs/Quaternion',
        'MSG: geometry_msgs/Vector3', 'MSG: std_msgs/Header']


def test_an_existing_path_is_never_overwritten_unless_asked(tmp_path):
    write_samples(tmp_path / 'bag', repeat=1)
    with pytest.raises(BagError, match='exists'):
        BagWriter(tmp_path / 'bag')
    assert len(list(read_bag(tmp_path / 'bag'))) == 7
    BagWriter(tmp_path / 'bag', overwrite=True).close()
    assert list(read_bag(tmp_path / 'bag')) == []
    other = tmp_path / 'notes'
    other.mkdir()
    (other / 'thesis.tex').write_text('precious')
    with pytest.raises(BagError, match='not part of a bag'):
        BagWriter(other, overwrite=True)
    assert (other / 'thesis.tex').read_text() == 'precious'


def test_bad_input_gets_a_clear_error(tmp_path):
    with pytest.raises(BagError, match='compression'):
        BagWriter(tmp_path / 'a', compression='gzip')
    with BagWriter(tmp_path / 'b') as bag:
        bag.add_topic('joint_states', 'sensor_msgs/msg/JointState')
        with pytest.raises(BagError, match='add_topic'):
            bag.write('deck/pose', cdr_bytes(PoseStamped()), 1)
        with pytest.raises(BagError, match='takes the CDR bytes'):
            bag.write('joint_states', JointState(), 1)
        with pytest.raises(msgdefs.MessageTypeError, match='pkg/msg/Name'):
            bag.add_topic('x', 'JointState')
        with pytest.raises(msgdefs.MessageTypeError, match='not installed'):
            bag.add_topic('x', 'no_such_msgs/msg/Thing')
    with pytest.raises(BagError, match='closed'):
        bag.write('joint_states', cdr_bytes(JointState()), 1)
    with pytest.raises(BagError, match='does not exist'):
        list(read_bag(tmp_path / 'missing'))


class _Quota(io.FileIO):
    """A real file on which the disk 'fills up' after ``limit`` bytes: writes then fail ENOSPC
    after writing what still fits, as write(2) does on a full file system."""

    def __init__(self, path, limit):
        super().__init__(path, 'xb')
        self.room = limit

    def write(self, data):
        if self.room <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        part = memoryview(data)[:self.room]
        n = super().write(part)
        self.room -= n
        return n


def test_disk_full_closes_the_bag_cleanly_readable_up_to_the_last_chunk(tmp_path):
    path = tmp_path / 'bag'
    bag = BagWriter(path, chunk_size=4096, opener=lambda p: _Quota(p, 40_000))
    bag.add_topic('spindle/speed_cmd', 'std_msgs/msg/Float64')
    written = 0
    with pytest.raises(BagWriteError) as info:
        for i in range(100_000):
            bag.write('spindle/speed_cmd', cdr_bytes(Float64(data=float(i))), 1000 + i)
            written += 1
    assert info.value.errno == errno.ENOSPC and 'readable' in str(info.value)
    assert bag.closed
    with pytest.raises(BagError, match='closed after a write error'):
        bag.write('spindle/speed_cmd', cdr_bytes(Float64()), 0)
    values = [m.data for _, m, _ in read_bag(path)]
    # What was read is exactly the prefix written, and only the chunk being written was lost
    # (a 4 KiB chunk holds < 4096 / 12 Float64 payloads). The message of the failed call may be
    # in the bag: its chunk can be whole with only the index after it cut off.
    assert values == [float(i) for i in range(len(values))]
    assert written - 4096 // 12 <= len(values) <= written + 1
    assert recover(path) == len(values)
    with AnyReader([path]) as reader:
        assert sum(1 for _ in reader.messages()) == len(values)


KILLED_WRITER = textwrap.dedent('''
    import os, signal, struct, sys
    from abb_ros.io.bag.writer import BagWriter
    bag = BagWriter(sys.argv[1], chunk_size=2048)
    bag.add_topic('spindle/speed_cmd', 'std_msgs/msg/Float64')
    for i in range(5000):
        # std_msgs/Float64 in CDR: encapsulation header, then the double.
        bag.write('spindle/speed_cmd', struct.pack('<4sd', b'\\0\\1\\0\\0', i), 1000 + i)
    os.kill(os.getpid(), signal.SIGKILL)
''')


def test_a_killed_writer_loses_at_most_the_chunk_in_progress(tmp_path):
    path = tmp_path / 'bag'
    proc = subprocess.run([sys.executable, '-c', KILLED_WRITER, str(path)], cwd=ROOT,
                          timeout=120)
    assert proc.returncode == -signal.SIGKILL
    values = [m.data for _, m, _ in read_bag(path)]
    # A 2 KiB chunk holds fewer than 2048 / 12 messages (12 CDR bytes each + record overhead).
    assert values == [float(i) for i in range(len(values))]
    assert 5000 - 2048 // 12 <= len(values) < 5000
    # metadata.yaml, last written when the topic was added, never claims more than the file holds
    info = yaml.safe_load((path / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['message_count'] <= len(values)
    # rosbags needs the summary (footer): recover() adds it, keeping every message.
    assert not is_finished(path)
    assert recover(path) == len(values) and is_finished(path)
    assert sorted(p.name for p in path.iterdir()) == ['bag_0.mcap', 'metadata.yaml']
    with AnyReader([path]) as reader:
        assert [reader.deserialize(raw, c.msgtype).data for c, _, raw in reader.messages()
                ] == values


@pytest.mark.ros
def test_message_objects_are_written_as_the_bytes_a_raw_subscription_receives():
    """Headless runs (rclpy objects) and the recorder (raw DDS bytes) write identical bags."""
    import time

    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    ctx = Context()
    rclpy.init(context=ctx)
    node = Node('bag_cdr_probe', context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    try:
        samples = sample_messages()
        received = {}
        pubs = []
        for i, (_, _, msg) in enumerate(samples):
            topic = f'probe_{i}'
            node.create_subscription(type(msg), topic,
                                     lambda data, i=i: received.setdefault(i, data), 10,
                                     raw=True)
            pubs.append(node.create_publisher(type(msg), topic, 10))
        deadline = time.monotonic() + 20
        while len(received) < len(samples) and time.monotonic() < deadline:
            for i, (_, _, msg) in enumerate(samples):
                if i not in received:
                    pubs[i].publish(msg)
            executor.spin_once(timeout_sec=0.1)
        assert len(received) == len(samples)
        for i, (_, type_name, msg) in enumerate(samples):
            assert received[i] == cdr_bytes(msg), type_name
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)


def test_message_sequence_numbers_count_from_zero_per_topic(tmp_path):
    from mcap.records import Channel, Message

    from abb_ros.io.bag.reader import iter_records
    with BagWriter(tmp_path / 'seq') as bag:
        bag.add_topic('a', 'std_msgs/msg/Float64')
        bag.add_topic('b', 'std_msgs/msg/Float64')
        for i in range(3):
            bag.write('a', bytes(12), i)
            bag.write('b', bytes(12), i)
    names, sequences = {}, {}
    for record in iter_records(tmp_path / 'seq'):
        if isinstance(record, Channel):
            names[record.id] = record.topic
        elif isinstance(record, Message):
            sequences.setdefault(names[record.channel_id], []).append(record.sequence)
    assert sequences == {'/a': [0, 1, 2], '/b': [0, 1, 2]}

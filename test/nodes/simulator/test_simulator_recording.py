"""In-process recording: the simulator writes exactly what it publishes, nothing lost.

1. ``record.path`` at real_time_factor 0 (the node owns time, as the headless run): the bag
   holds every message from step 0 on, byte-identical and in the same order as the headless
   ``run_scenario`` bag of the same scenario (test_live_vs_headless's parameters).
2. ``~/start_recording`` / ``~/stop_recording`` at real_time_factor 1 (in process, over DDS;
   ``max_stamp_lag`` 5 s so that a loaded machine makes the node catch up rather than drop
   periods): the bag is finished whole, its joint_states stamps are contiguous, each message
   equals the bytes a subscriber received with the same stamp, and every message the
   subscriber received within the recording's span is in the bag.
"""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import test_simulator_node
import yaml
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from test_live_vs_headless import SEED, node_parameters, stamp_of

from abb_ros.app.headless import STATE_TOPIC_TYPES, run_scenario
from abb_ros.io.bag.reader import is_finished, iter_raw
from abb_ros.io.bag.writer import BagWriter
from abb_ros.io.files.scenario import load_scenario
from abb_ros.io.wire import topics
from abb_ros.model.sensors.imu import TYPICAL_IMU

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[3]
PERIOD_NS = 1_000_000
RUN_S = 4.0
RAW_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
plant_factory = test_simulator_node.plant_factory   # the fixture, shared


def by_topic(bag: Path) -> dict[str, list[bytes]]:
    out = {}
    for topic, _, data, _ in iter_raw(bag):
        out.setdefault(topic, []).append(data)
    return out


def metadata_counts(bag: Path) -> dict[str, int]:
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    return {t['topic_metadata']['name']: t['message_count']
            for t in meta['topics_with_message_count']}


@pytest.mark.slow
def test_recording_in_the_node_equals_the_headless_bag_message_for_message(tmp_path):
    scenario = load_scenario('p3')
    live_bag = tmp_path / 'live'
    proc = subprocess.Popen(
        [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args',
         *node_parameters(scenario), '-p', f'record.path:={live_bag}'],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    deadline = time.monotonic() + 60
    while not (live_bag / 'metadata.yaml').exists():
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()[0]
        time.sleep(0.05)
    time.sleep(RUN_S)
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0, out
    assert is_finished(live_bag)
    live = by_topic(live_bag)
    assert {t: len(m) for t, m in live.items()} == metadata_counts(live_bag)

    last = stamp_of(live['/joint_states'][-1])
    scenario.duration = last * 1e-9
    with BagWriter(tmp_path / 'headless') as bag:
        run_scenario(scenario, imu_config=TYPICAL_IMU, seed=SEED, bag=bag)
    headless = by_topic(tmp_path / 'headless')
    assert last > 0.5e9, 'the node simulated less than 0.5 s'
    for topic in STATE_TOPIC_TYPES:
        name = topic if topic.startswith('/') else '/' + topic
        if topics.by_name(topic).rate == topics.SPEED:   # std_msgs/Float64: no stamp
            recorded = live[name][:len(headless[name])]   # one per sample, in order
        else:
            recorded = [d for d in live[name] if stamp_of(d) <= last]
            assert stamp_of(recorded[0]) == 0, f'{name}: the recording does not start at step 0'
        assert len(recorded) == len(headless[name]), (name, len(recorded),
                                                      len(headless[name]))
        differing = sum(a != b for a, b in zip(recorded, headless[name]))
        assert differing == 0, f'{name}: {differing} of {len(recorded)} messages differ'
    assert '/diagnostics' in live   # the node's own status is recorded too


@pytest.mark.slow
def test_recording_started_and_stopped_by_service_holds_what_a_subscriber_received(
        plant_factory, tmp_path):
    bag = tmp_path / 'bag'
    p = plant_factory(**{'record.path': '', 'max_stamp_lag': 5.0})
    p.sim.set_parameters([Parameter('record.path', value=str(bag))])
    received = {}
    p.node.create_subscription(JointState, 'joint_states',
                               lambda d: received.__setitem__(stamp_of(d), d), RAW_QOS,
                               raw=True)
    p.wait(lambda: len(received) > 10, 'joint_states')
    reply = p.call(Trigger, '/abb_simulator/start_recording', Trigger.Request())
    assert reply.success, reply.message
    again = p.call(Trigger, '/abb_simulator/start_recording', Trigger.Request())
    assert not again.success and 'already recording' in again.message
    p.spin_for(1.5)
    reply = p.call(Trigger, '/abb_simulator/stop_recording', Trigger.Request())
    assert reply.success and str(bag) in reply.message, reply.message
    p.spin_for(0.5)   # the subscriber's queue drains
    assert is_finished(bag)
    recorded = by_topic(bag)['/joint_states']
    stamps = [stamp_of(d) for d in recorded]
    assert len(stamps) > 300
    assert all(b - a == PERIOD_NS for a, b in zip(stamps, stamps[1:])), 'a gap in the bag'
    common = [d for d in recorded if stamp_of(d) in received]
    assert len(common) >= 0.9 * len(recorded)
    assert all(received[stamp_of(d)] == d for d in common)
    in_span = [s for s in received if stamps[0] <= s <= stamps[-1]]
    assert set(in_span) <= set(stamps), 'the subscriber got a message the bag lacks'
    assert not p.call(Trigger, '/abb_simulator/stop_recording', Trigger.Request()).success


@pytest.mark.slow
def test_recording_in_the_node_takes_the_other_nodes_topics_from_the_graph(plant_factory,
                                                                          tmp_path):
    """record.topics: another node's stability/margin, every one with its bytes, and
    /diagnostics from both nodes, the simulator's own statuses once each (they come through
    the middleware like the others'); the plant's topics as before, nothing lost."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.serialization import deserialize_message, serialize_message
    from std_msgs.msg import Float64

    bag = tmp_path / 'bag'
    p = plant_factory(**{'record.path': '', 'max_stamp_lag': 5.0,
                         'record.topics': ['stability/margin', '/diagnostics']})
    margin = p.node.create_publisher(Float64, 'stability/margin', 10)
    status = p.node.create_publisher(DiagnosticArray, '/diagnostics', 10)
    p.sim.set_parameters([Parameter('record.path', value=str(bag))])
    assert p.call(Trigger, '/abb_simulator/start_recording', Trigger.Request()).success
    p.wait(lambda: p.sim.recorder.current.graph.subscriptions.get('/stability/margin') is not None,
           'the subscription to stability/margin', timeout=10.0)
    sent = []
    for k in range(40):
        msg = Float64(data=0.01 * k)
        margin.publish(msg)
        sent.append(serialize_message(msg))
        if k % 10 == 0:
            status.publish(DiagnosticArray(status=[DiagnosticStatus(name='probe',
                                                                    message=str(k))]))
        p.spin_for(0.03)
    p.spin_for(1.5)   # at least one status of the simulator
    reply = p.call(Trigger, '/abb_simulator/stop_recording', Trigger.Request())
    assert reply.success, reply.message
    assert is_finished(bag)
    recorded = by_topic(bag)
    assert recorded['/stability/margin'] == sent
    assert {t: len(m) for t, m in recorded.items()} == metadata_counts(bag)
    names = {}
    for data in recorded['/diagnostics']:
        msg = deserialize_message(data, DiagnosticArray)
        for s in msg.status:
            names.setdefault(s.name.split(':')[0], []).append(
                (msg.header.stamp.sec, msg.header.stamp.nanosec, s.message))
    assert len(names['probe']) == 4
    own = names['/abb_simulator']
    assert own and len(own) == len(set(own)), 'a status of the simulator recorded twice'
    stamps = [stamp_of(d) for d in recorded['/joint_states']]
    assert len(stamps) > 300
    assert all(b - a == PERIOD_NS for a, b in zip(stamps, stamps[1:])), 'a gap in the bag'
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    lost = json.loads(meta['custom_data']['abb_ros.lost_messages'])
    assert lost.get('/stability/margin') == 0, lost


@pytest.mark.slow
def test_an_empty_record_topics_list_in_a_parameter_file_is_no_extra_topic(tmp_path):
    """rcl reads ``topics: []`` in a parameter file as no value; it means no other topic."""
    params = tmp_path / 'params.yaml'
    bag = tmp_path / 'bag'
    params.write_text(yaml.safe_dump({'/**': {'ros__parameters': {
        'record': {'path': str(bag), 'topics': []}}}}))
    proc = subprocess.Popen(
        [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args', '--params-file',
         str(params)], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    deadline = time.monotonic() + 60
    while not (bag / 'metadata.yaml').exists():
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()[0]
        time.sleep(0.05)
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0, out
    counts = metadata_counts(bag)
    own = {t.name if t.name.startswith('/') else '/' + t.name
           for t in topics.TOPICS if 'simulator' in t.publishers}
    assert '/joint_states' in counts and set(counts) <= own, counts


@pytest.mark.slow
@pytest.mark.parametrize('name', ['bad name!', 'x//y', '1abc', ''])
def test_a_bad_record_topic_is_refused_when_set_and_never_ends_the_node(plant_factory,
                                                                       tmp_path, name):
    """``record.topics = ['bad name!']`` at run time: refused with the parameter named; a
    recording asked for such a name answers failure and leaves no bag directory; the plant
    and ``~/start_recording`` work on."""
    bag = tmp_path / 'bag'
    p = plant_factory(**{'record.path': '', 'max_stamp_lag': 5.0})
    result = p.sim.set_parameters([Parameter('record.topics', value=[name])])[0]
    assert not result.successful and "'record.topics'" in result.reason, result.reason
    assert p.sim.get_parameter('record.topics').value == []
    error = p.sim.recorder.start(str(bag), [name])
    assert "'record.topics'" in error and not bag.exists()
    p.sim.set_parameters([Parameter('record.path', value=str(bag))])
    reply = p.call(Trigger, '/abb_simulator/start_recording', Trigger.Request())
    assert reply.success, reply.message
    assert p.call(Trigger, '/abb_simulator/stop_recording', Trigger.Request()).success
    assert is_finished(bag)

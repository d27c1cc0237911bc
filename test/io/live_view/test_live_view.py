"""The live view seen by clients the project did not write.

Foxglove's own WebSocket protocol client (npm ``@foxglove/ws-protocol``, run with node:
test/live_view_client/) connects to the simulator node's live view and to ``abb-sim run
--live-view``, and checks the channels (topics, schema names and encodings), that the
messages decode (rclpy) and equal the bytes published, and that the viewer's service calls,
published commands and parameter changes reach the node. Those tests skip, saying why, where
node or the npm package is missing (``npm ci --prefix test/live_view_client`` installs it). A
client made of tornado's WebSocket (no node needed) checks the wire format of the server
itself.
"""

from __future__ import annotations

import base64
import json
import shutil
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from abb_ros.app.run_sinks import Sinks
from abb_ros.io.live_view.server import LiveView, LiveViewError, parse_address
from abb_ros.io.live_view.services import service_texts
from abb_ros.io.wire import msgdefs

ROOT = Path(__file__).resolve().parents[3]
CLIENT_DIR = ROOT / 'test' / 'live_view_client'
DEADLINE_S = 30.0


def client_command() -> list[str]:
    """The command that runs Foxglove's client (skip, saying why, without node or npm)."""
    node = shutil.which('node')
    if node is None:
        pytest.skip('node is not installed: Foxglove\'s own client (npm) cannot run')
    if not (CLIENT_DIR / 'node_modules' / '@foxglove' / 'ws-protocol').is_dir():
        pytest.skip('the npm package @foxglove/ws-protocol is not installed: '
                    'npm ci --prefix test/live_view_client')
    return [node, str(CLIENT_DIR / 'client.mjs')]


def foxglove_client(url: str, timeout: float = DEADLINE_S, **options) -> dict:
    """Run Foxglove's client against ``url``; return what it saw (skip without node/npm)."""
    command = client_command()
    options.setdefault('timeout_s', timeout)
    out = subprocess.run([*command, url, '-'],
                         input=json.dumps(options), capture_output=True, text=True,
                         timeout=timeout + 15)   # options on stdin: large payloads
    assert out.returncode == 0, out.stderr + out.stdout
    return json.loads(out.stdout)


def b64(data: bytes) -> str:
    return base64.b64encode(data).decode()


def check_channels(seen: dict, expected: dict) -> None:
    """The channels are ``expected`` ({topic: type}), cdr with the bags' ros2msg schemas."""
    channels = {c['topic']: c for c in seen['channels']}
    assert set(channels) == set(expected)
    for topic, type_name in expected.items():
        channel = channels[topic]
        assert channel['encoding'] == 'cdr'
        assert channel['schemaName'] == type_name
        assert channel['schemaEncoding'] == 'ros2msg'
        assert channel['schema'] == msgdefs.full_text(type_name)


def check_messages(seen: dict, expected: dict, sent: dict, constant=None) -> int:
    """Every message received decodes and is the bytes sent with its stamp; returns the count.

    ``constant``: {topic: the bytes of its every message} for topics stamped on receipt.
    A value of ``sent`` may be a list: the messages of a topic sent with the same stamp
    (the simulator's two /diagnostics statuses).
    """
    count = 0
    for topic, messages in seen['messages'].items():
        cls = msgdefs.message_class(expected[topic])
        for message in messages:
            data = base64.b64decode(message['data'])
            deserialize_message(data, cls)
            if constant and topic in constant:
                assert data == constant[topic], topic
            else:
                same_stamp = sent[(topic, int(message['logTime']))]
                same_stamp = same_stamp if isinstance(same_stamp, list) else [same_stamp]
                assert data in same_stamp, topic
            count += 1
    return count


# ---- LiveView alone ---------------------------------------------------------------------------

def test_parse_address_defaults_to_loopback():
    assert parse_address('8765') == ('127.0.0.1', 8765)
    assert parse_address('0.0.0.0:0') == ('0.0.0.0', 0)
    assert parse_address('[::1]:9000') == ('::1', 9000)
    for bad in ('x', '70000', 'host:'):
        with pytest.raises(ValueError):
            parse_address(bad)


def test_service_texts_are_the_srv_halves():
    assert service_texts('std_srvs/srv/SetBool')[0].startswith('bool data')
    assert service_texts('std_srvs/srv/Trigger')[1].startswith('bool success')


def test_a_taken_port_is_refused():
    view = LiveView(port=0)
    try:
        with pytest.raises(LiveViewError, match=str(view.port)):
            LiveView(port=view.port)
    finally:
        view.close()


def feed(view: LiveView, stop: threading.Event, sent: dict) -> None:
    """Write spindle/speed and /clock every millisecond until ``stop``."""
    from rosgraph_msgs.msg import Clock
    k = 0
    while not stop.is_set():
        k += 1
        stamp = k * 1_000_000
        clock = Clock()
        clock.clock.nanosec = stamp
        for topic, data in (('spindle/speed', serialize_message(Float64(data=float(k)))),
                            ('/clock', serialize_message(clock))):
            sent[('/' + topic.lstrip('/'), stamp)] = data
            view.write(topic, data, stamp)
        time.sleep(0.001)


@pytest.fixture
def served():
    """A LiveView on a free loopback port with two topics, a service, written to meanwhile."""
    calls = []

    def pause(payload):
        calls.append(deserialize_message(payload, SetBool.Request).data)
        return serialize_message(SetBool.Response(success=True, message='paused'))

    view = LiveView(port=0, server_time=True,
                    services={'/abb_simulator/pause': ('std_srvs/srv/SetBool', pause)},
                    on_client_message=lambda *message: calls.append(message))
    view.add_topic('spindle/speed', 'std_msgs/msg/Float64')
    view.add_topic('/clock', 'rosgraph_msgs/msg/Clock')
    stop, sent = threading.Event(), {}
    thread = threading.Thread(target=feed, args=(view, stop, sent), daemon=True)
    thread.start()
    yield view, sent, calls
    stop.set()
    thread.join()
    view.close()


SUBPROTOCOLS = [None, 'foxglove.sdk.v1']
"""What the tests offer: the client's default (``foxglove.websocket.v1``: Lichtblick,
foxglove_bridge before 3.x) and foxglove-sdk's name (the current Foxglove app)."""


def offer(subprotocol) -> dict:
    """The client's options offering ``subprotocol`` (None: the client's default)."""
    return {} if subprotocol is None else dict(subprotocol=subprotocol)


@pytest.mark.parametrize('subprotocol', SUBPROTOCOLS)
def test_foxglove_client_sees_the_channels_messages_time_and_services(served, subprotocol):
    """Either subprotocol gets the whole protocol: channels, messages, time, services and
    published messages (the default one names the classic protocol, HTTP 400 before)."""
    view, sent, calls = served
    command = serialize_message(Float64(data=42.0))
    seen = foxglove_client(view.url, messages=3, **offer(subprotocol), publish=[
        dict(topic='spindle/speed_cmd', schemaName='std_msgs/msg/Float64', data=b64(command))],
        calls=[dict(service='/abb_simulator/pause',
                    data=b64(serialize_message(SetBool.Request(data=True))))])
    assert seen['subprotocol'] == (subprotocol or 'foxglove.websocket.v1')
    assert seen['serverInfo']['name'] == 'abb_ros'
    assert set(seen['serverInfo']['capabilities']) == {'time', 'clientPublish', 'services'}
    assert seen['serverInfo']['supportedEncodings'] == ['cdr']
    assert seen['serverInfo']['metadata'] == {'ROS_DISTRO': 'jazzy'}   # Studio's ROS 2 types
    expected = {'/spindle/speed': 'std_msgs/msg/Float64', '/clock': 'rosgraph_msgs/msg/Clock'}
    check_channels(seen, expected)
    assert check_messages(seen, expected, sent) == 6
    assert seen['time'] and all(('/clock', int(t)) in sent for t in seen['time'])
    [service] = seen['services']
    assert service['type'] == 'std_srvs/srv/SetBool'
    assert service['request']['schemaName'] == 'std_srvs/srv/SetBool_Request'
    assert service['request']['schemaEncoding'] == 'ros2msg'
    [response] = seen['responses']
    answer = deserialize_message(base64.b64decode(response['data']), SetBool.Response)
    assert answer.success and answer.message == 'paused'
    assert True in calls
    assert ('spindle/speed_cmd', 'std_msgs/msg/Float64', command) in calls


def test_tornado_websocket_client_reads_the_wire_format(served):
    """The protocol's frames, read with a generic WebSocket client (no node needed)."""
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    view, sent, _ = served

    async def session():
        ws = await websocket_connect(view.url, subprotocols=['foxglove.sdk.v1'])
        info = json.loads(await ws.read_message())
        assert info['op'] == 'serverInfo'
        channels = {}
        while len(channels) < 2:
            frame = await ws.read_message()
            if isinstance(frame, str) and json.loads(frame)['op'] == 'advertise':
                channels.update({c['topic']: c for c in json.loads(frame)['channels']})
        speed = channels['/spindle/speed']
        await ws.write_message(json.dumps({'op': 'subscribe', 'subscriptions': [
            {'id': 7, 'channelId': speed['id']}]}))
        while True:
            frame = await ws.read_message()
            if isinstance(frame, bytes) and frame[0] == 1:   # message data
                ws.close()
                return speed, frame

    speed, frame = IOLoop().run_sync(session, timeout=DEADLINE_S)
    assert (speed['encoding'], speed['schemaName']) == ('cdr', 'std_msgs/msg/Float64')
    subscription, stamp = struct.unpack_from('<IQ', frame, 1)
    assert subscription == 7
    assert frame[13:] == sent[('/spindle/speed', stamp)]


def test_sinks_hold_messages_until_their_stamp_is_due():
    now, slept, got = [0.0], [], []

    class Sink:
        def add_topic(self, topic, _type_name):
            got.append(topic)

        def write(self, topic, _data, _stamp_ns):
            got.append((topic, now[0]))

    def sleep(s):
        slept.append(s)
        now[0] += s

    sinks = Sinks([Sink(), Sink()], real_time=True, clock=lambda: now[0], sleep=sleep)
    sinks.add_topic('a', 'std_msgs/msg/Float64')
    for k in range(3):
        sinks.write('a', b'', 5_000_000_000 + k * 10_000_000)
    assert got == ['a', 'a', ('a', 0.0), ('a', 0.0), ('a', 0.01), ('a', 0.01), ('a', 0.02),
                   ('a', 0.02)]
    assert slept == pytest.approx([0.01, 0.01])


def test_sinks_write_a_samples_messages_to_every_sink_with_or_without_write_many():
    got = []

    class Each:                        # a MessageSink
        def add_topic(self, topic, type_name):
            pass

        def write(self, topic, data, stamp_ns):
            got.append(('each', topic, data, stamp_ns))

    class Many(Each):                  # a BatchSink
        def write_many(self, messages, stamp_ns):
            got.append(('many', list(messages), stamp_ns))

    pairs = [('a', b'1'), ('b', b'2')]
    Sinks([Each(), Many()]).write_many(pairs, 7)
    assert got == [('each', 'a', b'1', 7), ('each', 'b', b'2', 7), ('many', pairs, 7)]
    one = Many()
    assert Sinks([one]).write_many == one.write_many   # one unpaced sink: called directly

# ---- the simulator node -------------------------------------------------------------------------

@pytest.mark.ros
@pytest.mark.parametrize('subprotocol', SUBPROTOCOLS)
def test_simulator_node_serves_its_topics_and_takes_the_viewers_commands(subprotocol):
    from test_simulator_node import Plant

    from abb_ros.io.wire.ros_messages import TOPIC_TYPES

    # every message (no viewers' cap): the client pauses the plant as soon as it connects, and
    # at the cap's 100 a second too few of the 1 kHz states may arrive before that for three
    # of each (the cap: test_rate_cap.py, and at its default test_studio_viewer.py)
    plant = Plant(**{'live_view.enabled': True, 'live_view.port': 0,
                     'live_view.max_rate_hz': 0.0})
    margin = serialize_message(Float64(data=0.25))
    analysis = plant.node.create_publisher(Float64, 'stability/margin', 10)   # another node's
    stop = threading.Event()

    def publish_margin():
        while not stop.wait(0.01):
            analysis.publish(margin)

    threading.Thread(target=publish_margin, daemon=True).start()
    try:
        sim = plant.sim
        sent = {}
        write = sim.live.write

        def recording_write(name, data, stamp_ns):
            sent.setdefault((name, stamp_ns), []).append(data)
            write(name, data, stamp_ns)

        sim.live.write = recording_write
        expected = {sim.resolve_topic_name(t): msgdefs.type_name_of(cls())
                    for t, cls in TOPIC_TYPES.items()}
        expected['/stability/margin'] = 'std_msgs/msg/Float64'   # live_view.topics
        command = serialize_message(Float64(data=321.0))
        seen = foxglove_client(
            sim.live.view.url, messages=3, **offer(subprotocol),
            wait_for=['/joint_states', '/deck/imu', '/stability/margin'],
            publish=[dict(topic='spindle/speed_cmd', schemaName='std_msgs/msg/Float64',
                          data=b64(command))],
            get_parameters=['/abb_simulator.real_time_factor', '/abb_simulator.drive.n'],
            set_parameters=[dict(name='/abb_simulator.real_time_factor', value=2),
                            dict(name='/abb_simulator.drive.k', value=0),
                            dict(name='/abb_simulator.live_view.port', value=1)],
            calls=[dict(service='/abb_simulator/pause',
                        data=b64(serialize_message(SetBool.Request(data=True)))),
                   dict(service='/abb_simulator/step',
                        data=b64(serialize_message(Trigger.Request())))])
        if '/clock' not in {c['topic'] for c in seen['channels']}:
            del expected['/clock']   # advertised once carried: after the viewer's factor 2
        check_channels(seen, expected)
        assert check_messages(seen, expected, sent, {'/stability/margin': margin}) >= 9
        assert len(seen['messages']['/stability/margin']) == 3
        assert 'time' not in seen['serverInfo']['capabilities']   # wall-clock stamps
        assert {s['name'] for s in seen['services']} == {
            '/abb_simulator/pause', '/abb_simulator/step', '/abb_simulator/reset'}
        answers = [(deserialize_message(base64.b64decode(r['data']), SetBool.Response)
                    if r['serviceId'] == _service_id(seen, 'pause') else
                    deserialize_message(base64.b64decode(r['data']), Trigger.Response))
                   for r in seen['responses']]
        assert not seen['failures'] and len(answers) == 2
        assert sim.paused
        got = {p['name']: p['value'] for p in seen['parameters']['get']}
        assert got == {'/abb_simulator.real_time_factor': 1.0, '/abb_simulator.drive.n': 2}
        now = {p['name']: p['value'] for p in seen['parameters']['set']}
        assert now['/abb_simulator.real_time_factor'] == 2.0   # set, as ros2 param set does
        assert now['/abb_simulator.drive.k'] == sim.drive.k > 0   # refused: invalid
        assert now['/abb_simulator.live_view.port'] == 0   # refused: read-only
        assert sim.get_parameter('real_time_factor').value == 2.0
        deadline = time.monotonic() + DEADLINE_S
        while sim.speed_cmd != 321.0 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert sim.speed_cmd == 321.0   # through the ROS topic, as a ROS command
    finally:
        stop.set()
        plant.close()


@pytest.mark.ros
def test_a_taken_port_fails_the_start_up_naming_the_parameter(tmp_path):
    import rclpy
    from rclpy.parameter import Parameter

    from abb_ros.model.parameters.param_spec import ParamError
    from abb_ros.nodes.simulator.node import SimulatorNode

    taken = LiveView(port=0)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    try:
        overrides = [Parameter('live_view.enabled', value=True),
                     Parameter('live_view.port', value=taken.port),
                     Parameter('record.path', value=str(tmp_path / 'bag'))]
        with pytest.raises(ParamError, match='live_view.port'):
            SimulatorNode(context=ctx, parameter_overrides=overrides)
        from abb_ros.io.bag.reader import is_finished
        assert is_finished(tmp_path / 'bag')   # the recording begun is finished
    finally:
        rclpy.shutdown(context=ctx)
        taken.close()


def _service_id(seen: dict, name: str) -> int:
    return next(s['id'] for s in seen['services'] if s['name'].endswith('/' + name))


# ---- abb-sim run ------------------------------------------------------------------------------

def test_abb_sim_run_serves_the_headless_run_at_real_time(tmp_path):
    """The run lasts 8 s of wall time: node and the client start in a few seconds on a loaded
    machine, and the client must still see three messages of every topic."""
    from abb_ros.app.headless import STATE_TOPIC_TYPES

    run = subprocess.Popen(
        [sys.executable, '-m', 'abb_ros.cli', 'run', '--scenario', 'p1', '--duration', '8',
         '--live-view', '127.0.0.1:0', '--no-progress', '--out', str(tmp_path / 'bag')],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = run.stderr.readline()
        assert 'live view on ws://127.0.0.1:' in line, line
        url = line.split()[3]
        seen = foxglove_client(url, messages=3)
    finally:
        out, err = run.communicate(timeout=60)
    assert run.returncode == 0, err
    expected = {'/' + t.lstrip('/'): ty for t, ty in STATE_TOPIC_TYPES.items()}
    check_channels(seen, expected)
    assert 'time' in seen['serverInfo']['capabilities']
    from abb_ros.io.bag.reader import iter_raw
    sent = {('/' + t.lstrip('/'), stamp): data
            for t, _, data, stamp in iter_raw(tmp_path / 'bag')}
    assert check_messages(seen, expected, sent) == 3 * len(expected)
    assert 'live_view: ws://127.0.0.1:' in out
    wall = float(out.split('wall_time_s: ')[1].split()[0])
    assert wall >= 3.5   # paced at real time

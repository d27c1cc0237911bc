"""The live view against traffic a viewer should not send, and pages that should not connect.

Claims: a handshake is refused with a reason (HTTP 400 without a Foxglove subprotocol, 403 from
a browser page whose Origin is not allowed) while non-browser clients and the viewers' own
origins connect; whatever a connected client sends that the protocol does not have, or a
published message that is not exactly one message of its type, gets a status to that client
alone and goes no further; the simulator keeps running and takes the next valid command.
Foxglove's own client (npm ``@foxglove/ws-protocol``, test/live_view_client/) and tornado's
WebSocket client do the talking.
"""

from __future__ import annotations

import json
import struct
import threading
import time

import pytest
from rclpy.serialization import serialize_message
from std_msgs.msg import Float64
from test_live_view import DEADLINE_S, b64, foxglove_client

from abb_ros.io.live_view.admission import DEFAULT_ALLOWED_ORIGINS, origin_allowed
from abb_ros.io.live_view.server import LiveView

FOREIGN = 'https://attacker.example'


@pytest.fixture
def view():
    """A LiveView on a free port with one topic written every millisecond."""
    taken = []
    live = LiveView(port=0, on_client_message=lambda *m: taken.append(m),
                    check_client_message=lambda _topic, _schema, data: (
                        '' if len(data) == 12 else f'{len(data)} bytes'))
    live.add_topic('spindle/speed', 'std_msgs/msg/Float64')
    live.taken = taken
    stop = threading.Event()

    def feed():
        k = 0
        while not stop.wait(0.001):
            k += 1
            live.write('spindle/speed', serialize_message(Float64(data=float(k))), k * 1000)

    thread = threading.Thread(target=feed, daemon=True)
    thread.start()
    live.feeder = thread   # the writer's thread, as the plant's: it must outlive any viewer
    yield live
    stop.set()
    thread.join()
    live.close()


def handshake(url: str, subprotocols=('foxglove.websocket.v1',), origin=None,
              host=None) -> int:
    """The HTTP status of a WebSocket handshake with tornado's client (101: connected).

    ``host``: the Host header sent (default: that of ``url``, as every client sends).
    """
    from tornado.httpclient import HTTPClientError, HTTPRequest
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    headers = {'Origin': origin} if origin else {}
    if host is not None:
        headers['Host'] = host

    async def attempt():
        try:
            ws = await websocket_connect(HTTPRequest(url, headers=headers),
                                         subprotocols=list(subprotocols))
        except HTTPClientError as exc:
            return exc.code
        ws.close()
        return 101

    return IOLoop().run_sync(attempt, timeout=DEADLINE_S)


def test_the_default_origins_admit_the_viewers_and_no_foreign_page():
    for origin in ('https://app.foxglove.dev', 'file://', 'http://localhost:8080',
                   'http://127.0.0.1:3000', 'http://[::1]:8080', 'http://localhost'):
        assert origin_allowed(origin, DEFAULT_ALLOWED_ORIGINS), origin
    for origin in (FOREIGN, 'null', 'http://localhost.attacker.example',
                   'https://app.foxglove.dev.attacker.example', 'http://192.168.1.5:8080',
                   'http://localhost:8080.evil.com', 'http://127.0.0.1:80.evil.com',
                   'http://localhost:8080@evil.com', 'http://evil.com#.localhost',
                   'http://localhost:8080/path', 'https://app.foxglove.dev:8443',
                   'http://[::1]:8080.evil.com', 'http://localhost:99999'):
        assert not origin_allowed(origin, DEFAULT_ALLOWED_ORIGINS), origin
    assert origin_allowed(FOREIGN, ['*'])


def test_a_handshake_without_a_foxglove_subprotocol_gets_400_naming_both(view):
    assert handshake(view.url, subprotocols=()) == 400
    assert handshake(view.url, subprotocols=('chat',)) == 400
    assert handshake(view.url, subprotocols=('chat', 'foxglove.sdk.v1')) == 101


def test_a_client_offering_both_names_gets_the_first_it_lists(view):
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    async def selected(offered):
        ws = await websocket_connect(view.url, subprotocols=offered)
        chosen = ws.selected_subprotocol
        ws.close()
        return chosen

    for offered in (['foxglove.sdk.v1', 'foxglove.websocket.v1'],
                    ['foxglove.websocket.v1', 'foxglove.sdk.v1']):
        assert IOLoop().run_sync(lambda: selected(offered), timeout=DEADLINE_S) == offered[0]


def test_a_foreign_browser_origin_gets_403_and_the_viewers_origins_connect(view):
    assert handshake(view.url, origin=FOREIGN) == 403
    assert handshake(view.url, origin='null') == 403   # a sandboxed page
    seen = foxglove_client(view.url, origin=FOREIGN, messages=1)
    assert seen['handshake'] == 403 and not seen['channels']
    for origin in ('https://app.foxglove.dev', 'file://', 'http://localhost:8080', None):
        seen = foxglove_client(view.url, origin=origin, messages=1)
        assert 'handshake' not in seen, origin
        assert seen['messages']['/spindle/speed'], origin


def test_allowed_origins_are_the_servers_choice_and_a_refusal_is_logged_once():
    lines = []
    live = LiveView(port=0, allowed_origins=['https://lab.example'], log=lines.append)
    try:
        assert handshake(live.url, origin='https://lab.example') == 101
        assert handshake(live.url, origin='https://app.foxglove.dev') == 403
        assert handshake(live.url, origin='https://app.foxglove.dev') == 403
        assert handshake(live.url) == 101   # no Origin: not a browser
    finally:
        live.close()
    assert lines == ["live view: refused a handshake from 127.0.0.1: its Origin "
                     "'https://app.foxglove.dev' is not allowed (logged once)"]


def test_malformed_traffic_gets_a_status_to_its_client_and_the_server_goes_on(view):
    """Bad JSON, unknown operations and channels, a binary frame of no opcode, an oversized
    and an undersized message: each answered by an error status; messages keep coming."""
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    bad = ['{not json', '[1, 2]', json.dumps({'op': 'teleport'}),
           json.dumps({'op': 'subscribe', 'subscriptions': [{'id': 1, 'channelId': 99}]}),
           json.dumps({'op': 'subscribe', 'subscriptions': 'all'}),
           json.dumps({'op': 'advertise', 'channels': [{'id': 'x'}]}),
           b'\x07\x00', b'', struct.pack('<BI', 1, 5) + b'payload',
           json.dumps({'op': 'getParameters', 'parameterNames': []})]

    async def session():
        ws = await websocket_connect(view.url, subprotocols=['foxglove.websocket.v1'])
        other = await websocket_connect(view.url, subprotocols=['foxglove.sdk.v1'])
        for message in bad:
            await ws.write_message(message, binary=isinstance(message, bytes))
        await ws.write_message(json.dumps({'op': 'advertise', 'channels': [
            {'id': 3, 'topic': 'spindle/speed_cmd', 'encoding': 'cdr',
             'schemaName': 'std_msgs/msg/Float64'}]}))
        for payload in (b'\x00\x01\x00\x00' + bytes(9), bytes(100_000),
                        serialize_message(Float64(data=5.0))):
            await ws.write_message(struct.pack('<BI', 1, 3) + payload, binary=True)
        statuses = []
        while len(statuses) < len(bad) + 2:
            frame = await _read_with_timeout(ws, DEADLINE_S)
            assert frame is not None, 'the server closed the connection'
            if isinstance(frame, str) and json.loads(frame)['op'] == 'status':
                statuses.append(json.loads(frame))
        await ws.write_message(json.dumps({'op': 'subscribe', 'subscriptions': [
            {'id': 1, 'channelId': 1}]}))
        while True:   # the server goes on: messages come
            frame = await _read_with_timeout(ws, DEADLINE_S)
            if isinstance(frame, bytes) and frame[0] == 1:
                break
        others = []   # what the other client got meanwhile
        while (frame := await _read_with_timeout(other, 0.5)) is not None:
            others.append(frame)
        ws.close()
        other.close()
        return statuses, others

    statuses, others = IOLoop().run_sync(session, timeout=DEADLINE_S)
    assert all(s['level'] == 2 for s in statuses)
    texts = [s['message'] for s in statuses]
    assert any('not JSON' in t for t in texts)
    assert any('"teleport"' in t for t in texts)
    assert any('no channel 99' in t for t in texts)
    assert any('0x07' in t for t in texts)
    assert any('has not advertised' in t for t in texts)
    assert any('13 bytes' in t for t in texts) and any('100000 bytes' in t for t in texts)
    assert not any(isinstance(f, str) and json.loads(f)['op'] == 'status' for f in others)
    assert view.taken == [('spindle/speed_cmd', 'std_msgs/msg/Float64',
                           serialize_message(Float64(data=5.0)))]


async def _read_with_timeout(ws, seconds: float):
    import asyncio
    try:
        return await asyncio.wait_for(ws.read_message(), seconds)
    except asyncio.TimeoutError:
        return None


# ---- the simulator node -------------------------------------------------------------------------

BAD_PAYLOADS = {13: b'\x00\x01\x00\x00' + bytes(9), 16: b'\x00\x01\x00\x00' + bytes(12),
                20: b'\x00\x01\x00\x00' + bytes(16), 100_000: bytes(100_000),
                8: b'\x00\x01\x00\x00' + bytes(4)}
"""Payloads of a spindle command that are not one Float64 (12 bytes), by size."""


@pytest.mark.ros
def test_simulator_refuses_viewer_commands_that_are_not_one_float64_and_runs_on():
    from test_simulator_node import Plant

    plant = Plant(**{'live_view.enabled': True, 'live_view.port': 0,
                     'live_view.allowed_origins': ['https://lab.example']})
    try:
        sim = plant.sim
        url = sim.live.view.url
        good = serialize_message(Float64(data=123.0))
        publish = [dict(topic='spindle/speed_cmd', schemaName='std_msgs/msg/Float64',
                        data=b64(payload)) for payload in BAD_PAYLOADS.values()]
        publish += [dict(topic='deck/pose', schemaName='std_msgs/msg/Float64', data=b64(good)),
                    dict(topic='spindle/speed_cmd', schemaName='std_msgs/msg/Float64',
                         data=b64(good))]
        seen = foxglove_client(url, messages=1, wait_for=['/joint_states'], publish=publish,
                               statuses=len(BAD_PAYLOADS) + 1, origin='https://lab.example',
                               calls=[dict(service='/abb_simulator/pause',
                                           data=b64(b'\x00\x01\x00\x00\x01' + bytes(40)))])
        texts = [s['message'] for s in seen['statuses']]
        for size in BAD_PAYLOADS:
            assert any(f'{size} bytes' in t for t in texts), (size, texts)
        assert any('deck/pose' in t and 'only' in t for t in texts)
        [failure] = seen['failures']
        assert 'request refused' in failure['message'] and not sim.paused
        deadline = time.monotonic() + DEADLINE_S
        while sim.speed_cmd != 123.0 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert sim.speed_cmd == 123.0   # the valid command after the bad ones
        stamp = sim.stamp_ns()
        time.sleep(0.5)
        assert sim.stamp_ns() > stamp and not sim.fault   # still integrating
        refused = foxglove_client(url, origin='https://app.foxglove.dev', messages=1)
        assert refused['handshake'] == 403   # live_view.allowed_origins in force
    finally:
        plant.close()


# ---- ids, names and clients that go away -----------------------------------------------------

NOT_UINT32 = ['-1', '4294967296', '1e400', '1.5', 'true', '"1"', 'null', '1' + '0' * 30]
"""JSON texts of ids that are no uint32 of the protocol."""


async def _statuses(ws, count: int) -> list[str]:
    """Read until ``count`` status messages came; return their texts."""
    texts = []
    while len(texts) < count:
        frame = await _read_with_timeout(ws, DEADLINE_S)
        assert frame is not None, 'the server closed the connection'
        if isinstance(frame, str) and json.loads(frame)['op'] == 'status':
            status = json.loads(frame)
            assert status['level'] == 2, status
            texts.append(status['message'])
    return texts


def test_ids_that_are_no_uint32_get_a_status_naming_the_field_and_the_writer_lives_on(view):
    """Subscription, channel and advertised ids of -1, 2^32, 1e400, 1.5 (and unknown
    channels): one status each naming the field and the valid range; the connection stays,
    the writer's thread (the plant's, in the node) goes on, a valid subscription gets
    messages."""
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    bad = []
    for text in NOT_UINT32:
        bad += [('{"op":"subscribe","subscriptions":[{"id":%s,"channelId":1}]}' % text,
                 'subscriptions[0].id'),
                ('{"op":"subscribe","subscriptions":[{"id":7,"channelId":%s}]}' % text,
                 'subscriptions[0].channelId'),
                ('{"op":"advertise","channels":[{"id":%s,"topic":"spindle/speed_cmd",'
                 '"encoding":"cdr","schemaName":"std_msgs/msg/Float64"}]}' % text,
                 'channels[0].id'),
                ('{"op":"unsubscribe","subscriptionIds":[%s]}' % text, 'subscriptionIds[0]'),
                ('{"op":"unadvertise","channelIds":[%s]}' % text, 'channelIds[0]')]
    for channel in (0, 2, 99, 4294967295):   # unknown channels
        bad.append(('{"op":"subscribe","subscriptions":[{"id":%d,"channelId":%d}]}'
                    % (channel, channel), f'no channel {channel}'))

    async def session():
        ws = await websocket_connect(view.url, subprotocols=['foxglove.websocket.v1'])
        for text, _ in bad:
            await ws.write_message(text)
        texts = await _statuses(ws, len(bad))
        await ws.write_message(json.dumps({'op': 'subscribe', 'subscriptions': [
            {'id': 4294967295, 'channelId': 1}]}))   # the largest id is one
        while True:
            frame = await _read_with_timeout(ws, DEADLINE_S)
            assert frame is not None
            if isinstance(frame, bytes) and frame[0] == 1:
                ws.close()
                return texts, struct.unpack_from('<I', frame, 1)[0]

    texts, sub_id = IOLoop().run_sync(session, timeout=DEADLINE_S)
    for (text, field), got in zip(bad, texts):
        assert field in got, (text, got)
        if 'no channel' not in field:
            assert '[0, 4294967295]' in got, (text, got)
    assert sub_id == 4294967295
    time.sleep(0.1)
    assert view.feeder.is_alive()


def _log_lines(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno >= 30]


def test_clients_that_go_away_slow_readers_and_garbage_log_no_traceback(view, caplog):
    """20 clients that close (TCP reset) right after the handshake, one that subscribes and
    never reads, garbage JSON (huge numbers, deep nesting): no traceback, no 'Task exception
    was never retrieved', at most one line per kind; the server serves the next client."""
    import asyncio
    import gc
    import logging
    import socket

    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    caplog.set_level(logging.WARNING)
    port = view.port
    upgrade = (f'GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n'
               'Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n'
               'Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: foxglove.websocket.v1'
               '\r\n\r\n').encode()
    for _ in range(20):
        sock = socket.create_connection(('127.0.0.1', port))
        sock.sendall(upgrade)
        assert sock.recv(12) == b'HTTP/1.1 101'
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack('ii', 1, 0))
        sock.close()   # a reset, while the server writes its serverInfo and channels
    slow = socket.create_connection(('127.0.0.1', port))
    slow.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    slow.sendall(upgrade)
    slow.recv(12)
    subscribe = json.dumps({'op': 'subscribe',
                            'subscriptions': [{'id': 1, 'channelId': 1}]}).encode()
    slow.sendall(b'\x81' + bytes([0x80 | 126]) + len(subscribe).to_bytes(2, 'big')
                 + bytes(4) + subscribe)   # a masked text frame (mask 0)
    garbage = ['{"op":"subscribe","subscriptions":[{"id":1e400,"channelId":1e400}]}',
               '{"op":"setParameters","parameters":[{"name":"x","type":"float64",'
               '"value":1' + '0' * 400 + '}]}', '[' * 100_000, '{"op":' * 50_000,
               '{"op":"subscribe","subscriptions":[' + '{"id":1,"channelId":1},' * 5
               + '{"id":-1,"channelId":1}]}']

    async def session():
        ws = await websocket_connect(view.url, subprotocols=['foxglove.websocket.v1'])
        for text in garbage:
            await ws.write_message(text)
        await _statuses(ws, 4)
        await asyncio.sleep(1.5)   # the slow reader's socket fills meanwhile
        ws.close()
        ws = await websocket_connect(view.url, subprotocols=['foxglove.websocket.v1'])
        await ws.write_message(subscribe.decode())
        while not isinstance(frame := await _read_with_timeout(ws, DEADLINE_S), bytes):
            assert frame is not None
        ws.close()

    IOLoop().run_sync(session, timeout=DEADLINE_S)
    slow.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack('ii', 1, 0))
    slow.close()
    time.sleep(0.5)
    gc.collect()   # a task whose exception nobody took says so when it is collected
    time.sleep(0.2)
    assert not any(r.exc_info for r in caplog.records), _log_lines(caplog)
    lines = _log_lines(caplog)
    assert not any('never retrieved' in line or 'Traceback' in line for line in lines), lines
    assert len(lines) == len(set(lines)), lines
    assert view.feeder.is_alive()


def test_a_page_of_another_name_on_loopback_gets_403_dns_rebinding(view):
    """A server on loopback takes a Host of loopback only (a rebound name is refused even
    with its own Origin); origins are URLs, not prefixes."""
    port = view.port
    assert handshake(view.url, host='rebind.evil.example',
                     origin='http://rebind.evil.example') == 403
    assert handshake(view.url, host='rebind.evil.example') == 403   # no Origin: still 403
    assert handshake(view.url, host=f'rebind.evil.example:{port}') == 403
    assert handshake(view.url, host=f'localhost:{port}.evil.com') == 403
    assert handshake(view.url, origin='http://localhost:8080.evil.com') == 403
    assert handshake(view.url, origin='http://localhost:8080@evil.com') == 403
    for host in (f'127.0.0.1:{port}', f'localhost:{port}', 'localhost', f'[::1]:{port}',
                 '127.0.0.2'):
        assert handshake(view.url, host=host, origin='http://localhost:8080') == 101, host
    seen = foxglove_client(f'ws://localhost:{port}', messages=1)   # Foxglove's own client
    assert 'handshake' not in seen and seen['messages']['/spindle/speed']


def test_a_server_on_every_interface_takes_any_host_and_a_rebind_refusal_is_logged_once():
    lines = []
    every = LiveView(host='0.0.0.0', port=0, log=lines.append)
    local = LiveView(port=0, log=lines.append)
    try:
        assert not every.loopback and local.loopback
        assert handshake(f'ws://127.0.0.1:{every.port}', host='bench.lab.example') == 101
        for _ in range(2):
            assert handshake(local.url, host='rebind.evil.example') == 403
    finally:
        every.close()
        local.close()
    assert len(lines) == 1 and 'rebind.evil.example' in lines[0], lines
    assert 'loopback' in lines[0] and 'logged once' in lines[0]


@pytest.mark.parametrize('host, part, needle', [
    ('', 'host', 'every interface'), ('   ', 'host', 'every interface'),
    ('no-such-host.invalid', 'host', 'does not resolve'),
    ('192.0.2.1', 'host', 'cannot serve')])
def test_a_host_that_cannot_be_served_is_refused_as_the_host(host, part, needle):
    from abb_ros.io.live_view.server import LiveViewError
    with pytest.raises(LiveViewError) as err:
        LiveView(host=host, port=0)
    assert err.value.part == part and needle in str(err.value)
    assert '127.0.0.1' in str(err.value) and '\n' not in str(err.value)


@pytest.mark.ros
def test_the_plant_thread_outlives_a_viewer_subscribing_with_bad_ids_and_unknown_channels():
    from test_simulator_node import Plant
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    plant = Plant(**{'live_view.enabled': True, 'live_view.port': 0})
    try:
        sim = plant.sim

        async def session():
            ws = await websocket_connect(sim.live.view.url,
                                         subprotocols=['foxglove.websocket.v1'])
            subs = [{'id': i, 'channelId': c} for i in (-1, 2**32, 1.5) for c in (1, 2)]
            subs += [{'id': 9, 'channelId': c} for c in (0, 999, -1, 2**32)]
            await ws.write_message(json.dumps({'op': 'subscribe', 'subscriptions': subs}))
            texts = await _statuses(ws, len(subs))
            ws.close()
            return texts

        texts = IOLoop().run_sync(session, timeout=DEADLINE_S)
        assert all('subscriptions[' in t for t in texts), texts
        stamp = sim.stamp_ns()
        time.sleep(0.5)
        assert sim.stamp_ns() > stamp and not sim.fault   # still integrating
    finally:
        plant.close()


@pytest.mark.ros
@pytest.mark.parametrize('host, needle', [('', 'every interface'),
                                          ('no-such-host.invalid', 'does not resolve')])
def test_a_live_view_host_that_cannot_be_served_fails_the_start_up_naming_the_host(host,
                                                                                   needle):
    import rclpy
    from rclpy.parameter import Parameter

    from abb_ros.model.parameters.param_spec import ParamError
    from abb_ros.nodes.simulator.node import SimulatorNode

    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    try:
        overrides = [Parameter('live_view.enabled', value=True),
                     Parameter('live_view.host', value=host),
                     Parameter('live_view.port', value=0)]
        with pytest.raises(ParamError) as err:
            SimulatorNode(context=ctx, parameter_overrides=overrides)
        line = str(err.value)
        assert "'live_view.host'" in line and 'live_view.port' not in line
        assert needle in line and '127.0.0.1' in line and '\n' not in line
    finally:
        rclpy.shutdown(context=ctx)

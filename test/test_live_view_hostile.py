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
    yield live
    stop.set()
    thread.join()
    live.close()


def handshake(url: str, subprotocols=('foxglove.websocket.v1',), origin=None) -> int:
    """The HTTP status of a WebSocket handshake with tornado's client (101: connected)."""
    from tornado.httpclient import HTTPClientError, HTTPRequest
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    headers = {'Origin': origin} if origin else {}

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
                   'https://app.foxglove.dev.attacker.example', 'http://192.168.1.5:8080'):
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

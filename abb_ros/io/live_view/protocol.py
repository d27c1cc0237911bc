"""The Foxglove WebSocket protocol's messages, as bytes and JSON (no sockets here).

The protocol (the specification in the repository foxglove/ws-protocol) is served under two
subprotocol names, :data:`SUBPROTOCOLS`: ``foxglove.websocket.v1`` (foxglove_bridge before
3.x, Lichtblick, the default of the npm client ``@foxglove/ws-protocol``) and
``foxglove.sdk.v1`` (foxglove-sdk servers, foxglove_bridge 3.x, the current Foxglove app),
the same messages under a new name. A server sends JSON text (``serverInfo``, ``advertise``,
``status``...) and binary frames whose first byte is the opcode (message data, time, service
call response); a client sends JSON (``subscribe``, ``advertise``, ``getParameters``...) and
binary frames (its published messages, service call requests). Integers are little-endian.
"""

from __future__ import annotations

import base64
import collections
import json
import math
import struct

ENCODING = 'cdr'
SCHEMA_ENCODING = 'ros2msg'
BACKLOG = 5000
"""Messages queued per client before the oldest are dropped: 1 s of the node's 1 kHz topics
(foxglove-sdk keeps 1024, which a viewer starved of the CPU for 0.2 s overruns)."""

__all__ = ['SUBPROTOCOLS', 'U32_MAX', 'ClientFrame', 'WireError', 'message_data_prefix',
           'parameters_json', 'parameters_from_json', 'parse_client_binary',
           'service_response', 'status', 'text', 'time_frame', 'uint32']

SUBPROTOCOLS = ('foxglove.websocket.v1', 'foxglove.sdk.v1')
"""The subprotocols served: the protocol's classic name and foxglove-sdk's name of it."""

# binary opcodes, server to client
MESSAGE_DATA = 0x01
TIME = 0x02
SERVICE_CALL_RESPONSE = 0x03
# binary opcodes, client to server
CLIENT_MESSAGE_DATA = 0x01
SERVICE_CALL_REQUEST = 0x02

INFO, WARNING, ERROR = 0, 1, 2
"""Levels of a ``status`` message."""

_MESSAGE = struct.Struct('<BIQ')
_TIME = struct.Struct('<BQ')
_U32 = struct.Struct('<I')
U32_MAX = 2**32 - 1
"""The largest id of the protocol: subscription, channel, service, call and request ids are
uint32."""


class WireError(ValueError):
    """A client's message that is not one of the protocol (the text says what is wrong)."""


def uint32(value, field: str) -> int:
    """Return ``value`` if it is an id of the protocol (an integer in [0, 2^32 - 1]).

    Raises WireError naming ``field`` otherwise: JSON's 1.5, 1e400 (inf), -1, 2^32, true
    or "1" are no ids (a float is refused even when whole: clients send integers).
    """
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= U32_MAX:
        shown = repr(value)
        shown = shown if len(shown) <= 40 else shown[:37] + '...'
        raise WireError(f'{field} {shown} is not a uint32 id (an integer in [0, {U32_MAX}])')
    return value


def text(op: str, **fields) -> str:
    """Return the JSON text of operation ``op`` with ``fields``."""
    return json.dumps({'op': op, **fields}, separators=(',', ':'))


def status(level: int, message: str) -> str:
    """Return a ``status`` message (``level``: INFO, WARNING or ERROR) for a client."""
    return text('status', level=level, message=message)


def message_data_prefix(subscription_id: int, stamp_ns: int) -> bytes:
    """Return the bytes that precede a message's payload in a message data frame."""
    return _MESSAGE.pack(MESSAGE_DATA, subscription_id, stamp_ns)


def time_frame(stamp_ns: int) -> bytes:
    """Return a ``time`` frame: the server's current time [ns]."""
    return _TIME.pack(TIME, stamp_ns)


def service_response(service_id: int, call_id: int, encoding: str, payload: bytes) -> bytes:
    """Return a service call response frame."""
    name = encoding.encode()
    return (struct.pack('<BIII', SERVICE_CALL_RESPONSE, service_id, call_id, len(name))
            + name + payload)


class ClientFrame:
    """A client's binary frame: a published message or a service call request.

    ``kind`` is ``'message'`` (``channel_id``, ``payload``) or ``'call'`` (``service_id``,
    ``call_id``, ``encoding``, ``payload``).
    """

    def __init__(self, kind: str, payload: bytes, channel_id: int = 0, service_id: int = 0,
                 call_id: int = 0, encoding: str = ''):
        self.kind, self.payload = kind, payload
        self.channel_id, self.service_id, self.call_id = channel_id, service_id, call_id
        self.encoding = encoding


def parse_client_binary(frame: bytes) -> ClientFrame:
    """Read a client's binary frame; raises WireError for one the protocol does not have."""
    if not frame:
        raise WireError('an empty binary message')
    op = frame[0]
    if op == CLIENT_MESSAGE_DATA:
        if len(frame) < 5:
            raise WireError(f'a message data frame of {len(frame)} bytes (at least 5)')
        return ClientFrame('message', bytes(frame[5:]), channel_id=_U32.unpack_from(frame, 1)[0])
    if op == SERVICE_CALL_REQUEST:
        if len(frame) < 13:
            raise WireError(f'a service call request of {len(frame)} bytes (at least 13)')
        service_id, call_id, length = struct.unpack_from('<III', frame, 1)
        if 13 + length > len(frame):
            raise WireError('a service call request whose encoding runs past its end')
        try:
            encoding = bytes(frame[13:13 + length]).decode()
        except UnicodeDecodeError:
            raise WireError('a service call request whose encoding is not UTF-8') from None
        return ClientFrame('call', bytes(frame[13 + length:]), service_id=service_id,
                           call_id=call_id, encoding=encoding)
    raise WireError(f'binary opcode {op:#04x} (a client sends 0x01 or 0x02)')


def parameters_json(values) -> list:
    """Return the protocol's parameters of [(name, value)]; a float keeps its type.

    JSON has one number type, so a float is marked ``float64`` (an array of floats
    ``float64_array``), bytes are ``byte_array`` in base64.
    """
    out = []
    for name, value in values:
        entry = {'name': name, 'value': value}
        if isinstance(value, float):
            entry['type'] = 'float64'
            if not math.isfinite(value):   # JSON has no inf or nan: the text, marked float64
                entry['value'] = repr(value)
        elif (isinstance(value, list) and value
              and all(isinstance(v, float) for v in value)):
            entry['type'] = 'float64_array'
        elif isinstance(value, (bytes, bytearray)):
            entry['type'], entry['value'] = 'byte_array', base64.b64encode(value).decode()
        out.append(entry)
    return out


def parameters_from_json(entries) -> list:
    """Return [(name, value)] of a client's ``setParameters`` list (WireError: malformed)."""
    if not isinstance(entries, list):
        raise WireError('"parameters" is not a list')
    out = []
    for entry in entries:
        if not isinstance(entry, dict) or not isinstance(entry.get('name'), str):
            raise WireError('a parameter without a "name"')
        value, kind = entry.get('value'), entry.get('type')
        try:
            if kind == 'float64':
                value = float(value)
            elif kind == 'float64_array':
                value = [float(v) for v in value]
            elif kind == 'byte_array':
                value = base64.b64decode(value, validate=True)
        except (TypeError, ValueError, OverflowError) as exc:
            raise WireError(f'parameter {entry["name"]}: {exc}') from None
        out.append((entry['name'], value))
    return out


def queue_of() -> collections.deque:
    """Return a client's queue of outgoing frames: the oldest fall out beyond BACKLOG."""
    return collections.deque(maxlen=BACKLOG)


def json_of(message: str) -> dict:
    """Return a client's JSON text as a dict; raises WireError when it is not one."""
    try:
        value = json.loads(message)
    except ValueError as exc:
        raise WireError(f'not JSON ({exc})') from None
    except RecursionError:
        raise WireError('not JSON this server reads (nested too deeply)') from None
    if not isinstance(value, dict) or not isinstance(value.get('op'), str):
        raise WireError('a JSON message without "op"')
    return value

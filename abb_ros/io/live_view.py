"""A live view: the messages of a run served on a Foxglove WebSocket server (foxglove-sdk).

The Foxglove app opens ``ws://HOST:PORT`` (Open connection, Foxglove WebSocket) and shows the
topics live, as it shows a bag. :class:`LiveView` takes what a bag takes, with the same
calls as :class:`abb_ros.io.bag_writer.BagWriter` (:meth:`LiveView.add_topic`,
:meth:`LiveView.write`: topic, CDR bytes, stamp): each topic is a channel with message
encoding ``cdr`` and the ``ros2msg`` schema text rosbag2 stores (:mod:`abb_ros.io.msgdefs`),
so the app decodes the messages as it decodes a bag's. Relative topic names are served
absolute (``joint_states`` as ``/joint_states``), as in the root namespace of ROS.

What a viewer may send back, where the protocol has it:

* ``clientPublish``: a message the viewer publishes (the Publish panel, encoding ``cdr``) is
  handed to ``on_client_message(topic, schema_name, data)``, from the server's thread;
* ``services``: each of ``services`` (name -> (ROS service type, handler)) is advertised with
  its ``ros2msg`` request and response schemas; ``handler(request_cdr)`` runs on the
  server's thread and returns the response's CDR bytes (an exception: the call fails, with
  its text);
* ``parameters``: ``parameters.get(names)`` and ``parameters.set([(name, value)])`` (both
  return [(name, value)]: all for an empty ``names``; after a set, the values then in
  force) back the app's Parameters panel, from the server's thread;
* ``time``: with ``server_time``, every message on ``/clock`` also sets the viewer's current
  time to its stamp (the app then plays in simulated time).

No rclpy here: the bytes are encoded by the caller.
"""

from __future__ import annotations

__all__ = ['DEFAULT_HOST', 'DEFAULT_PORT', 'LiveView', 'LiveViewError', 'parse_address',
           'service_texts']

import re

import foxglove
from foxglove.websocket import Capability, ServerListener

from abb_ros.io import msgdefs
from abb_ros.io.topics import CLOCK_TOPIC

DEFAULT_HOST = '127.0.0.1'
"""The server listens on loopback unless told otherwise: it has no authentication."""
DEFAULT_PORT = 8765
"""The Foxglove WebSocket port the app proposes (and foxglove_bridge uses)."""
ENCODING = 'cdr'
SCHEMA_ENCODING = 'ros2msg'
SERVER_NAME = 'abb_ros'


class LiveViewError(RuntimeError):
    """The live view could not be served (the port is taken, the host is not local...)."""


def parse_address(text: str) -> tuple[str, int]:
    """Split ``[HOST:]PORT`` into (host, port); HOST defaults to :data:`DEFAULT_HOST`.

    Raises ValueError for a port that is not an integer in [0, 65535] (0: any free port).
    """
    host, _, port = text.rpartition(':')
    host = host.strip('[]') or DEFAULT_HOST
    try:
        number = int(port)
    except ValueError:
        raise ValueError(f'{text!r} is not [HOST:]PORT') from None
    if not 0 <= number <= 65535:
        raise ValueError(f'port {number} is not in [0, 65535]')
    return host, number


def service_texts(type_name: str) -> tuple[str, str]:
    """Return the request and response ``ros2msg`` texts of service ``pkg/srv/Name``."""
    package, _, name = type_name.split('/')
    text = (msgdefs.share_dir(package) / 'srv' / f'{name}.srv').read_text()
    request, response = re.split(r'^---[ \t]*$', text, maxsplit=1, flags=re.M)
    return request.strip() + '\n', response.strip() + '\n'


def _absolute(topic: str) -> str:
    return topic if topic.startswith('/') else '/' + topic


class LiveView:
    """A Foxglove WebSocket server serving CDR messages by topic.

    Parameters
    ----------
    host : str
        Address the server binds to (default loopback).
    port : int
        Its port; 0 takes any free port (:attr:`port` tells which).
    server_time : bool
        Whether the stamps are simulated time: the ``time`` capability, and the viewer's time
        follows ``/clock``.
    services : dict
        Service name -> (ROS service type ``pkg/srv/Name``, handler(request CDR) -> response
        CDR).
    on_client_message : callable or None
        Called with (topic, schema name, CDR bytes) for each message a viewer publishes;
        None: viewers cannot publish.
    parameters : object or None
        The parameters a viewer gets and sets (``get``, ``set``; see the module docstring);
        None: no parameters.
    """

    def __init__(self, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT,
                 server_time: bool = False, services=None, on_client_message=None,
                 parameters=None):
        self._context = foxglove.Context()
        self._channels: dict[str, object] = {}
        self._clock = None
        self._client_channels: dict[tuple[int, int], object] = {}
        self._on_client_message = on_client_message
        capabilities = []
        if server_time:
            capabilities.append(Capability.Time)
        if on_client_message is not None:
            capabilities.append(Capability.ClientPublish)
        if parameters is not None:
            capabilities.append(Capability.Parameters)
        self.parameters = parameters
        advertised = [self._service(name, *spec) for name, spec in (services or {}).items()]
        if advertised:
            capabilities.append(Capability.Services)
        self._server_time = server_time
        try:
            self.server = foxglove.start_server(
                name=SERVER_NAME, host=host, port=port, capabilities=capabilities,
                server_listener=_Listener(self), supported_encodings=[ENCODING],
                services=advertised, context=self._context)
        except RuntimeError as exc:
            raise LiveViewError(f'cannot serve the live view on {host}:{port}: {exc}') from None
        self.host = host
        self.port = self.server.port
        self.closed = False

    @property
    def url(self) -> str:
        """The address the Foxglove app opens: ``ws://HOST:PORT``."""
        host = f'[{self.host}]' if ':' in self.host else self.host
        return f'ws://{host}:{self.port}'

    def _service(self, name: str, type_name: str, handler):
        request, response = service_texts(type_name)

        def schema(text: str, part: str):
            return foxglove.MessageSchema(encoding=ENCODING, schema=foxglove.Schema(
                name=f'{type_name}_{part}', encoding=SCHEMA_ENCODING, data=text.encode()))

        return foxglove.Service(
            name, schema=foxglove.ServiceSchema(type_name, request=schema(request, 'Request'),
                                           response=schema(response, 'Response')),
            handler=lambda call: handler(bytes(call.payload)))

    def has_topic(self, topic: str) -> bool:
        """Whether ``topic`` is served."""
        return _absolute(topic) in self._channels

    def add_topic(self, topic: str, type_name: str, **_bag_only) -> None:
        """Serve ``topic`` of message type ``type_name`` (a bag's qos and type_hash: unused)."""
        name = _absolute(topic)
        if name in self._channels:
            return
        full = msgdefs.normalize_type(type_name)
        schema = foxglove.Schema(name=full, encoding=SCHEMA_ENCODING,
                                       data=msgdefs.full_text(full).encode())
        channel = foxglove.Channel(name, schema=schema, message_encoding=ENCODING,
                                         context=self._context)
        self._channels[name] = channel
        if name == CLOCK_TOPIC and self._server_time:
            self._clock = channel

    def write(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Send one message (CDR bytes) of ``topic`` to the viewers subscribed to it."""
        channel = self._channels.get(topic) or self._channels[_absolute(topic)]
        channel.log(data, log_time=stamp_ns)
        if channel is self._clock:
            self.server.broadcast_time(stamp_ns)

    def _client_message(self, client_id: int, channel_id: int, data: bytes) -> None:
        channel = self._client_channels.get((client_id, channel_id))
        if channel is None or channel.encoding != ENCODING:
            return
        self._on_client_message(channel.topic, channel.schema_name, data)

    def close(self) -> None:
        """Stop the server (the viewers see the connection close); idempotent."""
        if self.closed:
            return
        self.closed = True
        self.server.stop()
        for channel in self._channels.values():
            channel.close()


class _Listener(ServerListener):
    """The server's callbacks: the channels viewers advertise and the messages they send."""

    def __init__(self, view: LiveView):
        self._view = view

    def on_client_advertise(self, client, channel) -> None:
        self._view._client_channels[(client.id, channel.id)] = channel

    def on_client_unadvertise(self, client, client_channel_id: int) -> None:
        self._view._client_channels.pop((client.id, client_channel_id), None)

    def on_message_data(self, client, client_channel_id: int, data: bytes) -> None:
        if self._view._on_client_message is not None:
            self._view._client_message(client.id, client_channel_id, data)

    def on_get_parameters(self, client, param_names, request_id=None):
        return _parameters(self._view.parameters.get(list(param_names)))

    def on_set_parameters(self, client, parameters, request_id=None):
        wanted = [(p.name, p.get_value()) for p in parameters]
        return _parameters(self._view.parameters.set(wanted))


def _parameters(values) -> list:
    """Foxglove parameters of [(name, value)]; a float keeps its type on the wire."""
    out = []
    for name, value in values:
        kind = None
        if isinstance(value, float):
            kind = foxglove.ParameterType.Float64
        elif isinstance(value, list) and value and all(isinstance(v, float) for v in value):
            kind = foxglove.ParameterType.Float64Array
        out.append(foxglove.Parameter(name, value=value, type=kind))
    return out

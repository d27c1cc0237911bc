"""A live view: the messages of a run served on a Foxglove WebSocket server.

The Foxglove app, Lichtblick, or any client of the Foxglove WebSocket protocol opens
``ws://HOST:PORT`` and shows the topics live, as it shows a bag. The server speaks the
protocol under both its subprotocol names (:data:`abb_ros.io.live_view.protocol.SUBPROTOCOLS`:
``foxglove.websocket.v1`` and ``foxglove.sdk.v1``) on tornado's WebSocket server, in a thread
of its own. :class:`LiveView` takes what a bag takes, with the same calls as
:class:`abb_ros.io.bag.writer.BagWriter` (:meth:`LiveView.add_topic`, :meth:`LiveView.write`:
topic, CDR bytes, stamp): each topic is a channel with message encoding ``cdr`` and the
``ros2msg`` schema text rosbag2 stores (:mod:`abb_ros.io.wire.msgdefs`), so a viewer decodes the
messages as it decodes a bag's. Relative topic names are served absolute (``joint_states`` as
``/joint_states``), as in the root namespace of ROS. A message is sent only to the clients
subscribed to its channel, at most ``max_rate_hz`` a second of its stamps
(:mod:`abb_ros.io.live_view.rate_cap`); a client that reads more slowly than the messages come
loses the oldest ones beyond :data:`~abb_ros.io.live_view.protocol.BACKLOG` (counted,
:attr:`LiveView.dropped`).

What a viewer may send back, where the protocol has it:

* ``clientPublish``: a message the viewer publishes (the Publish panel, encoding ``cdr``) is
  first shown to ``check_client_message(topic, schema_name, data)``, which returns why it is
  refused ('' to take it): a refused message goes no further and its client gets a ``status``
  (error) saying why; a taken one is handed to ``on_client_message(topic, schema_name,
  data)``; both run on the server's thread;
* ``services``: each of ``services`` (name -> (ROS service type, handler)) is advertised with
  its ``ros2msg`` request and response schemas; ``handler(request_cdr)`` runs in a worker
  thread and returns the response's CDR bytes (an exception: the call fails, with its text);
* ``parameters``: ``parameters.get(names)`` and ``parameters.set([(name, value)])`` (both
  return [(name, value)]: all for an empty ``names``; after a set, the values then in
  force) back the Parameters panel, in a worker thread;
* ``time``: with ``server_time``, every message on ``/clock`` also sets the viewer's current
  time to its stamp (the viewer then plays in simulated time).

Anything else a client sends that the protocol does not have (bad JSON, an unknown channel or
service, a malformed binary frame, an id that is no uint32: -1, 2^32, 1.5, 1e400) is answered
by a ``status`` (error) to that client naming the field; the server goes on, and the writer's
thread never sees it. A client that goes away, even in the middle of a write, is no error;
anything the server's loop could not do is logged in one line, once (never a traceback).
A frame larger than :data:`MAX_MESSAGE_BYTES` closes that client's
connection (code 1009).

Handshakes: a client offering neither subprotocol gets HTTP 400 naming both. A browser sends
the page's ``Origin``; one not matched by ``allowed_origins`` (shell patterns, ``*`` for any)
gets HTTP 403, so a web page open in a browser on this machine cannot drive the bench. A
handshake without ``Origin`` (not a browser: node or Python clients, ros tools) is taken.
Origins are read as URLs (scheme, host, port: :mod:`abb_ros.io.live_view.admission`). On a
server that listens on loopback, a handshake whose ``Host`` does not name loopback (DNS
rebinding) gets HTTP 403 too.
:data:`DEFAULT_ALLOWED_ORIGINS` admits the Foxglove web app, desktop apps (Electron pages
loaded from ``file://``: the Foxglove and Lichtblick desktop apps) and pages served from this
machine (a self-hosted Lichtblick at ``http://localhost:8080``), and no other web origin.

No rclpy here: the bytes are encoded by the caller.
"""

from __future__ import annotations

__all__ = ['DEFAULT_HOST', 'DEFAULT_PORT', 'MAX_MESSAGE_BYTES', 'LiveView', 'LiveViewError',
           'parse_address']

import asyncio
import logging
import threading
import time
from concurrent.futures import ThreadPoolExecutor

from abb_ros.io.live_view import protocol as wire
from abb_ros.io.live_view.admission import (
    DEFAULT_ALLOWED_ORIGINS,
    DEFAULT_HOST,
    DEFAULT_PORT,
    is_loopback,
)
from abb_ros.io.live_view.protocol import ENCODING, SCHEMA_ENCODING
from abb_ros.io.live_view.rate_cap import RateCap, slot_ns
from abb_ros.io.live_view.services import service_info
from abb_ros.io.wire import msgdefs
from abb_ros.io.wire.topics import CLOCK_TOPIC

SERVER_NAME = 'abb_ros'
MAX_MESSAGE_BYTES = 16 * 1024 * 1024
"""The largest frame a client may send [bytes]."""
START_TIMEOUT_S = 10.0
ROS_DISTRO = 'jazzy'
"""The ``ROS_DISTRO`` of ``serverInfo``'s metadata, as foxglove_bridge sends it: Foxglove Studio
and Lichtblick then know ROS 2's common message definitions (the Publish panel lists them)."""
FLUSH_PERIOD_S = 0.005
"""How often the messages queued for the viewers are sent [s]: the writer never waits for
the server's thread, and a viewer gets them in batches (up to 5 ms late)."""


class LiveViewError(RuntimeError):
    """The live view could not be served (the port is taken, the host is not local...).

    ``part`` says which half of the address is at fault: ``'host'`` (empty, does not
    resolve, not an address of this machine) or ``'port'`` (taken, not allowed).
    """

    def __init__(self, reason: str, part: str = 'port'):
        self.reason, self.part = reason, part
        super().__init__(f'{reason}; give {HOST_VALID}' if part == 'host' else reason)


HOST_VALID = ('a loopback address (127.0.0.1, the default; ::1; localhost) or an address '
              'of this machine (0.0.0.0: every interface, with no authentication)')
"""What a live view's host may be (for messages)."""


def _bind(host: str, port: int):
    """Return the listening sockets of ``host``:``port``; LiveViewError says which is wrong."""
    import errno
    import socket

    from tornado import netutil
    if not isinstance(host, str) or not host.strip():
        raise LiveViewError(f'host {host!r} is empty, which would listen on every interface',
                            part='host')
    try:
        socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except (socket.gaierror, UnicodeError) as exc:
        why = getattr(exc, 'strerror', None) or str(exc)
        raise LiveViewError(f'host {host!r} does not resolve ({why})', part='host') from None
    try:
        return netutil.bind_sockets(port, address=host)
    except (OSError, ValueError) as exc:
        part = 'host' if getattr(exc, 'errno', None) == errno.EADDRNOTAVAIL else 'port'
        raise LiveViewError(f'cannot serve the live view on {host}:{port}: {exc}',
                            part=part) from None


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


def _absolute(topic: str) -> str:
    return topic if topic.startswith('/') else '/' + topic


class _Channel:
    """A served topic; ``subscribers`` is replaced, never changed (read from any thread)."""

    def __init__(self, channel_id: int, topic: str, type_name: str):
        self.id, self.topic = channel_id, topic
        self.info = dict(id=channel_id, topic=topic, encoding=ENCODING, schemaName=type_name,
                         schema=msgdefs.full_text(type_name), schemaEncoding=SCHEMA_ENCODING)
        self.subscribers: tuple = ()   # ((connection, subscription id), ...)
        self.cap = RateCap()


class LiveView:
    """A Foxglove WebSocket server serving CDR messages by topic (see the module docstring).

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
        The parameters a viewer gets and sets (``get``, ``set``); None: no parameters.
    check_client_message : callable or None
        (topic, schema name, CDR bytes) -> why a viewer's message is refused ('' to take
        it); None takes every message in encoding ``cdr``.
    allowed_origins : sequence of str
        Browser origins admitted (shell patterns); handshakes without Origin always are.
    log : callable or None
        Called with a line for each kind of refused handshake (from the server's thread).
    max_rate_hz : float
        The most messages of one channel sent per second of their stamps (0: every one;
        ValueError if negative or not finite).
    """

    def __init__(self, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT,
                 server_time: bool = False, services=None, on_client_message=None,
                 parameters=None, check_client_message=None,
                 allowed_origins=DEFAULT_ALLOWED_ORIGINS, log=None, max_rate_hz=0.0):
        self._slot_ns = slot_ns(max_rate_hz)
        self._channels: dict[str, _Channel] = {}
        self._by_id: dict[int, _Channel] = {}
        self._clock = None
        self._server_time = server_time
        self.on_client_message = on_client_message
        self.check_client_message = check_client_message
        self.parameters = parameters
        self.allowed_origins = tuple(allowed_origins)
        self._log = log
        self._refusals_logged: set[tuple[int, str]] = set()
        self.services = {}
        for k, (name, (type_name, handler)) in enumerate((services or {}).items(), start=1):
            self.services[k] = (name, type_name, handler)
        capabilities = []
        if server_time:
            capabilities.append('time')
        if on_client_message is not None:
            capabilities.append('clientPublish')
        if parameters is not None:
            capabilities.append('parameters')
        if self.services:
            capabilities.append('services')
        self.server_info = wire.text(
            'serverInfo', name=SERVER_NAME, capabilities=capabilities,
            supportedEncodings=[ENCODING], metadata={'ROS_DISTRO': ROS_DISTRO},
            sessionId=str(time.time_ns()))
        self.dropped = 0
        self.connections: set = set()
        self._flushing = False   # whether _flush is scheduled (server thread only)
        sockets = _bind(host, port)
        self.host = host
        self.port = sockets[0].getsockname()[1]
        self.loopback = all(is_loopback(s.getsockname()[0]) for s in sockets)
        """Whether the server listens on loopback only (then a handshake's Host is checked)."""
        self._logged: set[str] = set()
        self._workers = ThreadPoolExecutor(max_workers=2, thread_name_prefix='live_view')
        self._loop = asyncio.new_event_loop()
        self._server = None
        started = threading.Event()
        self._thread = threading.Thread(target=self._serve, args=(sockets, started),
                                        name='live_view', daemon=True)
        self._thread.start()
        started.wait(START_TIMEOUT_S)
        self.closed = False

    @property
    def url(self) -> str:
        """The address a viewer opens: ``ws://HOST:PORT``."""
        host = f'[{self.host}]' if ':' in self.host else self.host
        return f'ws://{host}:{self.port}'

    # ---- the server's thread --------------------------------------------------------------
    def _serve(self, sockets, started: threading.Event) -> None:
        from tornado.httpserver import HTTPServer
        from tornado.web import Application

        from abb_ros.io.live_view.connection import Connection
        asyncio.set_event_loop(self._loop)
        self._loop.set_exception_handler(self._loop_error)
        app = Application([(r'/.*', Connection, dict(view=self))],
                          websocket_max_message_size=MAX_MESSAGE_BYTES,
                          log_function=self._log_request)
        self._server = HTTPServer(app)
        self._server.add_sockets(sockets)
        started.set()
        try:
            self._loop.run_forever()
        finally:
            self._loop.close()

    def log_once(self, line: str) -> None:
        """Log ``line`` (one line, no traceback) the first time it comes (any thread)."""
        if line in self._logged or len(self._logged) > 1000:
            return
        self._logged.add(line)
        if self._log is not None:
            self._log(line)
        else:
            logging.getLogger('abb_ros.live_view').warning(line)

    def _loop_error(self, _loop, context: dict) -> None:
        """Log an error of the server's loop in one line; a viewer gone is no error."""
        from tornado.iostream import StreamClosedError
        from tornado.websocket import WebSocketClosedError
        exc = context.get('exception')
        if isinstance(exc, (WebSocketClosedError, StreamClosedError, ConnectionError)):
            return
        what = context.get('message') or 'an error'
        why = f' ({type(exc).__name__}: {exc})'.splitlines()[0][:200] if exc else ''
        self.log_once(f'live view: {what}{why}')

    def _log_request(self, handler) -> None:
        """Log a refused handshake once per status, Origin and Host (else nothing)."""
        status = handler.get_status()
        if status < 400 or self._log is None:
            return
        origin = handler.request.headers.get('Origin', '')
        host = getattr(handler, 'refused_host', '')
        if (status, origin + host) in self._refusals_logged:
            return
        self._refusals_logged.add((status, origin + host))
        why = {400: 'it offered no Foxglove subprotocol',
               403: host or f'its Origin {origin!r} is not allowed'}.get(status,
                                                                        f'HTTP {status}')
        self._log(f'live view: refused a handshake from {handler.request.remote_ip}: {why} '
                  '(logged once)')

    def _on_loop(self, fn, *args) -> None:
        """Run ``fn(*args)`` on the server's thread (from any thread)."""
        if not self.closed:
            try:
                self._loop.call_soon_threadsafe(fn, *args)
            except RuntimeError:   # the loop is closed: the server has stopped
                pass

    def _flush(self) -> None:
        """Send what was queued; again in FLUSH_PERIOD_S while a viewer is connected."""
        for connection in list(self.connections):
            connection.send_queued()
        if self.connections:
            self._loop.call_later(FLUSH_PERIOD_S, self._flush)
        else:
            self._flushing = False

    def start_flushing(self) -> None:
        """Send the queued messages every FLUSH_PERIOD_S (a viewer has connected)."""
        if not self._flushing:
            self._flushing = True
            self._loop.call_later(FLUSH_PERIOD_S, self._flush)

    def run_in_worker(self, fn, *args):
        """Return an awaitable of ``fn(*args)`` run in a worker thread (calls that block)."""
        return self._loop.run_in_executor(self._workers, fn, *args)

    def channel(self, channel_id: int):
        """Return the channel of ``channel_id`` (None: no such channel)."""
        return self._by_id.get(channel_id)

    def subscribe(self, connection, subscription_id: int, channel: _Channel) -> None:
        """Send ``channel``'s messages to ``connection`` under ``subscription_id``.

        The id is checked here too (a uint32: the writer's thread packs it), so that no
        subscription can make :meth:`write` fail.
        """
        wire.uint32(subscription_id, 'subscription id')
        channel.subscribers = tuple(
            (c, s) for c, s in channel.subscribers
            if (c, s) != (connection, subscription_id)) + ((connection, subscription_id),)

    def unsubscribe(self, connection, subscription_id: int | None = None) -> None:
        """Drop a subscription of ``connection`` (every one of it for None)."""
        for channel in self._channels.values():
            if any(c is connection for c, _ in channel.subscribers):
                channel.subscribers = tuple(
                    (c, s) for c, s in channel.subscribers
                    if c is not connection or (subscription_id is not None
                                               and s != subscription_id))

    def advertisement(self) -> list[str]:
        """Return the texts a new client gets after ``serverInfo``: channels, services."""
        out = []
        if self._channels:
            out.append(wire.text('advertise',
                                 channels=[c.info for c in self._channels.values()]))
        if self.services:
            out.append(wire.text('advertiseServices', services=[
                service_info(k, name, type_name)
                for k, (name, type_name, _) in self.services.items()]))
        return out

    def _broadcast_text(self, message: str) -> None:
        for connection in list(self.connections):
            connection.send_text(message)

    # ---- any thread -----------------------------------------------------------------------
    def subscriber_count(self, topic: str) -> int:
        """Return how many subscriptions of viewers ``topic`` has (0: not served)."""
        channel = self._channels.get(_absolute(topic))
        return 0 if channel is None else len(channel.subscribers)

    def has_topic(self, topic: str) -> bool:
        """Whether ``topic`` is served."""
        return _absolute(topic) in self._channels

    def add_topic(self, topic: str, type_name: str, **_bag_only) -> None:
        """Serve ``topic`` of message type ``type_name`` (a bag's qos and type_hash: unused)."""
        name = _absolute(topic)
        if name in self._channels:
            return
        channel = _Channel(len(self._by_id) + 1, name, msgdefs.normalize_type(type_name))
        self._by_id[channel.id] = channel
        self._channels = {**self._channels, name: channel}
        if name == CLOCK_TOPIC and self._server_time:
            self._clock = channel
        self._on_loop(self._broadcast_text, wire.text('advertise', channels=[channel.info]))

    def remove_topic(self, topic: str) -> None:
        """Stop serving ``topic`` (its viewers see it unadvertised); unknown: nothing."""
        channels = dict(self._channels)
        channel = channels.pop(_absolute(topic), None)
        if channel is None:
            return
        self._channels = channels
        channel.subscribers = ()
        if channel is self._clock:
            self._clock = None
        self._on_loop(self._broadcast_text, wire.text('unadvertise', channelIds=[channel.id]))

    def write(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Send one message (CDR bytes) of ``topic`` to its viewers, unless over the cap."""
        channel = self._channels.get(topic) or self._channels[_absolute(topic)]
        if not channel.cap.keeps(stamp_ns, self._slot_ns):
            return
        subscribers = channel.subscribers
        if subscribers:
            for connection, subscription_id in subscribers:
                self.dropped += connection.queue(
                    wire.message_data_prefix(subscription_id, stamp_ns) + data)
        if channel is self._clock and self.connections:
            frame = wire.time_frame(stamp_ns)
            for connection in list(self.connections):
                self.dropped += connection.queue(frame)

    def write_many(self, messages, stamp_ns: int) -> None:
        """Send several messages of one stamp, (topic, CDR bytes) pairs: :meth:`write` each."""
        for topic, data in messages:
            self.write(topic, data, stamp_ns)

    def close(self) -> None:
        """Stop the server (the viewers see the connection close); idempotent."""
        if self.closed:
            return
        done = threading.Event()

        def stop():
            if self._server is not None:
                self._server.stop()
            for connection in list(self.connections):
                connection.close(1001, 'server stopped')
            self._loop.call_later(0.05, self._loop.stop)
            done.set()

        self._on_loop(stop)
        self.closed = True
        done.wait(START_TIMEOUT_S)
        self._thread.join(START_TIMEOUT_S)
        self._workers.shutdown(wait=False, cancel_futures=True)

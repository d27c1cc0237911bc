"""One viewer's connection to the live view: its handshake and the operations it sends.

A tornado WebSocket handler, on the server's thread (:class:`abb_ros.io.live_view.server.LiveView`
holds what the connections share and documents what a viewer may do). The handshake takes
either subprotocol name of the Foxglove WebSocket protocol and checks the browser's origin;
then the connection gets ``serverInfo``, the channels and the services, and its operations are
carried out (subscriptions, published messages, service calls, parameters). What it sends that
the protocol does not have is answered by a ``status`` (error) to it alone.
"""

from __future__ import annotations

__all__ = ['Connection', 'quiet']

from tornado.websocket import WebSocketClosedError, WebSocketHandler

from abb_ros.io.live_view import protocol as wire
from abb_ros.io.live_view.admission import host_problem, origin_allowed
from abb_ros.io.live_view.protocol import ENCODING, json_of, queue_of


class Connection(WebSocketHandler):
    """A viewer connected to the live view ``view``."""

    def initialize(self, view) -> None:
        """Start the state of a connection to ``view`` (tornado calls it)."""
        self.view = view
        self.outbox = queue_of()
        self.client_channels: dict[int, dict] = {}
        self.subscriptions: dict[int, int] = {}   # subscription id -> channel id
        self._flushing = None   # the write future of the last frame sent, while pending
        self.refused_host = ''   # why the handshake's Host was refused ('' if it was not)

    # ---- handshake ------------------------------------------------------------------------
    def _offered(self) -> list[str]:
        header = self.request.headers.get('Sec-WebSocket-Protocol', '')
        return [p.strip() for p in header.split(',') if p.strip()]

    async def get(self, *args, **kwargs) -> None:
        """Refuse a handshake of the wrong name or subprotocol, else accept it.

        On a server that listens on loopback, a ``Host`` that does not name loopback gets
        HTTP 403 (DNS rebinding: :mod:`abb_ros.io.live_view.admission`); a handshake offering
        neither subprotocol gets HTTP 400.
        """
        why = host_problem(self.request.headers.get('Host')) if self.view.loopback else ''
        if why:
            self.refused_host = why
            self.set_status(403)
            self.finish(f'{why}: this server listens on loopback and takes no other name\n')
            return
        if not any(p in wire.SUBPROTOCOLS for p in self._offered()):
            self.set_status(400)
            self.finish('a Foxglove WebSocket client offers the subprotocol '
                        + ' or '.join(wire.SUBPROTOCOLS) + '\n')
            return
        await super().get(*args, **kwargs)

    def select_subprotocol(self, subprotocols):
        """Return the first subprotocol offered that is served."""
        return next((p for p in subprotocols if p in wire.SUBPROTOCOLS), None)

    def check_origin(self, origin: str) -> bool:
        """Whether a browser page of ``origin`` may connect (else HTTP 403)."""
        return origin_allowed(origin, self.view.allowed_origins)

    def open(self, *_args, **_kwargs) -> None:
        """Send ``serverInfo``, the channels and the services."""
        self.set_nodelay(True)
        self.view.connections.add(self)
        self.view.start_flushing()
        self.send_text(self.view.server_info)
        for text in self.view.advertisement():
            self.send_text(text)

    def on_close(self) -> None:
        """Forget the connection's subscriptions and queued frames."""
        self.view.connections.discard(self)
        self.view.unsubscribe(self)
        self.outbox.clear()

    # ---- to the viewer --------------------------------------------------------------------
    def send_text(self, text: str) -> None:
        """Send a JSON text now (control messages are not queued behind data)."""
        try:
            quiet(self.write_message(text))
        except WebSocketClosedError:
            pass

    def refuse(self, why: str) -> None:
        """Tell this viewer (alone) that what it sent was refused, and why."""
        self.send_text(wire.status(wire.ERROR, why))

    def queue(self, frame: bytes) -> int:
        """Queue a binary frame (from any thread); returns 1 if an older one fell out."""
        full = len(self.outbox) == self.outbox.maxlen
        self.outbox.append(frame)
        return int(full)

    def send_queued(self) -> None:
        """Send the queued frames, unless the socket has not taken the last ones yet."""
        if self._flushing is not None:
            return
        future = None
        try:
            while self.outbox:
                future = quiet(self.write_message(self.outbox.popleft(), binary=True))
        except (WebSocketClosedError, IndexError):
            return
        if future is not None and not future.done():
            self._flushing = future
            future.add_done_callback(self._sent)

    def _sent(self, _future) -> None:
        self._flushing = None
        self.send_queued()

    # ---- from the viewer ------------------------------------------------------------------
    def on_message(self, message) -> None:
        """Carry out one operation of the viewer; refuse with a status what is not one.

        Whatever the viewer sent, the server goes on: an error this code did not foresee is
        refused like the others (and logged in one line, once per kind), never raised into
        tornado (which would log a traceback and drop the connection).
        """
        try:
            if isinstance(message, bytes):
                self._binary(wire.parse_client_binary(message))
            else:
                self._operation(json_of(message))
        except wire.WireError as exc:
            self.refuse(f'not taken: {exc}')
        except Exception as exc:   # noqa: BLE001 - a viewer's input never stops the server
            why = f'{type(exc).__name__}: {exc}'.splitlines()[0][:200]
            self.view.log_once(f'live view: a viewer\'s message was not carried out ({why})')
            self.refuse(f'not taken: this server could not carry it out ({why})')

    def _operation(self, op: dict) -> None:
        name = op['op']
        handler = getattr(self, '_op_' + name, None)
        if handler is None:
            raise wire.WireError(f'operation "{name}" is not served here')
        try:
            handler(op)
        except (KeyError, TypeError, ValueError, AttributeError, ArithmeticError,
                RecursionError) as exc:
            if isinstance(exc, wire.WireError):
                raise
            raise wire.WireError(f'a malformed "{name}" ({type(exc).__name__}: {exc})') from None

    def _entries(self, op: dict, key: str) -> list:
        """Return the list ``op[key]`` (WireError naming ``key`` when it is not one)."""
        entries = op.get(key)
        if not isinstance(entries, list):
            raise wire.WireError(f'"{op["op"]}": "{key}" is not a list')
        return entries

    def _each(self, op: dict, key: str, take) -> None:
        """Call ``take(entry, field)`` for each entry of ``op[key]``; refuse the bad ones.

        An entry that is not valid gets its own status (naming ``key[i]`` and what is
        valid); the others are carried out.
        """
        for k, entry in enumerate(self._entries(op, key)):
            try:
                take(entry, f'{key}[{k}]')
            except wire.WireError as exc:
                self.refuse(f'{op["op"]}: {exc}')

    def _op_subscribe(self, op: dict) -> None:
        def take(entry, field):
            if not isinstance(entry, dict):
                raise wire.WireError(f'{field} is not an object with "id" and "channelId"')
            sub_id = wire.uint32(entry.get('id'), f'{field}.id')
            channel_id = wire.uint32(entry.get('channelId'), f'{field}.channelId')
            channel = self.view.channel(channel_id)
            if channel is None or not self.view.has_topic(channel.topic):
                raise wire.WireError(f'no channel {channel_id} ({field}.channelId: a channel '
                                     'advertised to this client)')
            self.view.unsubscribe(self, sub_id)
            self.subscriptions[sub_id] = channel_id
            self.view.subscribe(self, sub_id, channel)
        self._each(op, 'subscriptions', take)

    def _op_unsubscribe(self, op: dict) -> None:
        def take(entry, field):
            sub_id = wire.uint32(entry, field)
            self.subscriptions.pop(sub_id, None)
            self.view.unsubscribe(self, sub_id)
        self._each(op, 'subscriptionIds', take)

    def _op_advertise(self, op: dict) -> None:
        if self.view.on_client_message is None:
            raise wire.WireError('this server takes no published messages (no clientPublish)')

        def take(channel, field):
            if not isinstance(channel, dict):
                raise wire.WireError(f'{field} is not an object with "id", "topic" and '
                                     '"encoding"')
            channel_id = wire.uint32(channel.get('id'), f'{field}.id')
            texts = {}
            for name, default in (('topic', None), ('encoding', None), ('schemaName', '')):
                value = channel.get(name, default)
                if not isinstance(value, str):
                    raise wire.WireError(f'{field}.{name} is not a string')
                texts[name] = value
            self.client_channels[channel_id] = dict(id=channel_id, **texts)
        self._each(op, 'channels', take)

    def _op_unadvertise(self, op: dict) -> None:
        def take(entry, field):
            self.client_channels.pop(wire.uint32(entry, field), None)
        self._each(op, 'channelIds', take)

    def _op_getParameters(self, op: dict) -> None:   # noqa: N802 - the protocol's name
        names = op['parameterNames']
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise wire.WireError('"parameterNames" is not a list of names')
        self._parameters(self._parameter_source().get, list(names), _request_id(op))

    def _op_setParameters(self, op: dict) -> None:   # noqa: N802 - the protocol's name
        wanted = wire.parameters_from_json(op['parameters'])
        self._parameters(self._parameter_source().set, wanted, _request_id(op), reply=False)

    def _parameter_source(self):
        if self.view.parameters is None:
            raise wire.WireError('this server has no parameters')
        return self.view.parameters

    def _parameters(self, fn, argument, request_id, reply: bool = True) -> None:
        async def run():
            try:
                values = await self.view.run_in_worker(fn, argument)
            except Exception as exc:   # noqa: BLE001 - told to the viewer
                self.refuse(f'parameters: {exc}')
                return
            if reply or request_id is not None:
                fields = dict(parameters=wire.parameters_json(values))
                if request_id is not None:
                    fields['id'] = request_id
                self.send_text(wire.text('parameterValues', **fields))
        self.view._loop.create_task(run())

    def _binary(self, frame: wire.ClientFrame) -> None:
        if frame.kind == 'message':
            self._client_message(frame)
        else:
            self._service_call(frame)

    def _client_message(self, frame: wire.ClientFrame) -> None:
        view = self.view
        channel = self.client_channels.get(frame.channel_id)
        if view.on_client_message is None:
            raise wire.WireError('this server takes no published messages (no clientPublish)')
        if channel is None:
            raise wire.WireError(f'a message on channel {frame.channel_id}, which this client '
                                 'has not advertised')
        topic, schema_name = channel['topic'], channel['schemaName']
        why = (f'encoding {channel["encoding"]!r} (this server takes {ENCODING!r})'
               if channel['encoding'] != ENCODING else '')
        if not why and view.check_client_message is not None:
            why = view.check_client_message(topic, schema_name, frame.payload)
        if why:
            self.refuse(f'{topic} [{schema_name}] not published: {why}')
            return
        view.on_client_message(topic, schema_name, frame.payload)

    def _service_call(self, frame: wire.ClientFrame) -> None:
        service = self.view.services.get(frame.service_id)

        def fail(message: str) -> None:
            self.send_text(wire.text('serviceCallFailure', serviceId=frame.service_id,
                                     callId=frame.call_id, message=message))

        if service is None:
            fail(f'no service {frame.service_id}')
            return
        if frame.encoding != ENCODING:
            fail(f'encoding {frame.encoding!r} (this server takes {ENCODING!r})')
            return
        _, _, handler = service

        async def run():
            try:
                response = await self.view.run_in_worker(handler, frame.payload)
            except Exception as exc:   # noqa: BLE001 - told to the viewer
                fail(str(exc) or type(exc).__name__)
                return
            try:
                quiet(self.write_message(wire.service_response(
                    frame.service_id, frame.call_id, ENCODING, response), binary=True))
            except WebSocketClosedError:
                pass
        self.view._loop.create_task(run())


def _retrieve(future) -> None:
    if not future.cancelled():
        future.exception()   # a viewer gone meanwhile: nothing to tell (and no log)


def quiet(future):
    """Return the write ``future``, whose failure (the viewer has gone) is taken as said.

    Left alone, each frame written to a connection that closes would log "Task exception
    was never retrieved" with a WebSocketClosedError traceback.
    """
    future.add_done_callback(_retrieve)
    return future


def _request_id(op: dict):
    """Return a parameter request's ``id``: a string, or None without one."""
    request_id = op.get('id')
    if request_id is not None and not isinstance(request_id, str):
        raise wire.WireError(f'"id" {request_id!r:.40} is not a string (a request id)')
    return request_id

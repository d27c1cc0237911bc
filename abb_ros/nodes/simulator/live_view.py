"""The simulator's live view: what it publishes on a Foxglove WebSocket server, and back.

``live_view.enabled`` serves every topic the node publishes, from the CDR bytes it publishes
and records (:class:`abb_ros.io.live_view.server.LiveView`, on
``live_view.host``:``live_view.port``), stamped as in its bag, and the other nodes' topics
``live_view.topics`` (the analysis node's ``stability/margin`` of the shipped layout...), taken
from the middleware as the in-process recording takes ``record.topics``
(:class:`abb_ros.nodes.recorder.recording.GraphRecording`), stamped with their receive time; a
topic this node also publishes then comes through the middleware with the others' messages.
``/clock`` is advertised only while the node publishes it: from start-up when it does then
(real_time_factor other than 1, or ``start_paused``), else from its first message
(:mod:`abb_ros.runtime.sim_clock`); a server started with ``/clock`` has the ``time`` capability
and the viewer's time follows it (the capabilities are fixed when the server starts).

What the viewer can do (the Foxglove WebSocket protocol's capabilities):

* ``services``: the node's ``~/pause`` (std_srvs/SetBool), ``~/step`` and ``~/reset``
  (std_srvs/Trigger), by their ROS names (the Service Call panel): the call runs the node's
  own service callback, on the node's thread, and answers what a ROS client gets;
* ``clientPublish``: ``spindle/speed_cmd`` and ``spindle/current_cmd`` (std_msgs/Float64,
  the Publish panel) are published on the ROS topic, as foxglove_bridge does, so the node
  takes them through its subscription like any command (and a recording sees them). A message
  is checked first, on the server's thread (:func:`message_problem`): one on another topic or
  of another type, or whose payload is not exactly one CDR message of its type (12 bytes for
  a Float64), is refused with a status to the viewer that sent it (logged once per topic and
  reason) and never reaches the middleware or the plant; a service request is checked the
  same way (its call fails with the reason).
* ``parameters``: the node's parameters, named ``/abb_simulator.real_time_factor`` as
  foxglove_bridge names them (the Parameters panel), got and set as ``ros2 param`` does
  (:class:`ViewerParameters`): the plant's speed is ``real_time_factor``.

The server calls back from its own thread: those calls are queued and carried out by a
timer of the node every :data:`COMMAND_PERIOD_S` (steady clock, so also while paused); a
service call or a parameter request waits for its answer up to :data:`SERVICE_TIMEOUT_S`.
"""

from __future__ import annotations

import queue
import threading

from rclpy.clock import Clock, ClockType
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import Float64

from abb_ros.io.live_view.admission import DEFAULT_ALLOWED_ORIGINS
from abb_ros.io.live_view.server import HOST_VALID, LiveView, LiveViewError
from abb_ros.io.wire import msgdefs, topics
from abb_ros.model.parameters.param_spec import ParamError
from abb_ros.nodes.recorder.recording import DRAIN_PERIOD_S, GraphRecording

__all__ = ['COMMAND_PERIOD_S', 'SERVICE_TIMEOUT_S', 'SimulatorLiveView', 'ViewerParameters',
           'message_problem', 'start']

COMMAND_PERIOD_S = 0.02
"""How often the viewer's commands are carried out on the node's thread [s]."""
SERVICE_TIMEOUT_S = 5.0
"""How long a viewer's service call waits for the node [s]."""
COMMAND_TYPE = 'std_msgs/msg/Float64'
DISCOVERY_S = 0.5
"""How often the graph is searched for the ``live_view.topics`` [s]."""
DEPTH = 100
"""Queue depth of each subscription to another node's topic."""


class SimulatorLiveView:
    """The live view of one simulator node (see the module docstring).

    Parameters
    ----------
    node : abb_ros.nodes.simulator.node.SimulatorNode
        The node served.
    host, port
        Where the server listens (``live_view.host``, ``live_view.port``).
    services : dict
        Service short name (``pause``) -> (service class, the node's callback).
    served : dict
        The node's topics (resolved names) -> message type name.
    others : list of str
        Other nodes' topics served too.
    allowed_origins : sequence of str
        Browser origins that may connect (``live_view.allowed_origins``).
    max_rate_hz : float
        The most messages of one topic sent a second (``live_view.max_rate_hz``).
    """

    def __init__(self, node, host: str, port: int, services: dict, served: dict, others=(),
                 allowed_origins=DEFAULT_ALLOWED_ORIGINS, max_rate_hz=0.0):
        self.node = node
        self._calls = queue.SimpleQueue()
        self._command_topics = {node.resolve_topic_name(t.name): t.name
                                for t in topics.TOPICS if t.rate == topics.COMMAND}
        self._command_pubs = {}
        self._refused: set[tuple[str, str, str]] = set()
        base = node.get_fully_qualified_name()
        handlers = {f'{base}/{name}': (_srv_type(cls), self._service(cls, callback))
                    for name, (cls, callback) in services.items()}
        self.parameters = ViewerParameters(node)
        self.view = LiveView(host, port, server_time=node.pacer.publishes_clock,
                             services=handlers, on_client_message=self._client_message,
                             parameters=self, check_client_message=self.check_client_message,
                             allowed_origins=allowed_origins,
                             log=node.get_logger().warning, max_rate_hz=max_rate_hz)
        clock = node.resolve_topic_name(topics.CLOCK_TOPIC)
        self._unadvertised = ({} if node.pacer.publishes_clock or clock not in served
                              else {clock: served[clock]})
        """Topics advertised at their first message: ``/clock`` while it is silent."""
        for name, type_name in served.items():
            if name not in self._unadvertised:
                self.view.add_topic(name, type_name)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._timers = [node.create_timer(COMMAND_PERIOD_S, self._carry_out, clock=steady)]
        self.graph = None
        if others:
            self.graph = GraphRecording(node, self.view, others, DEPTH,
                                        param='live_view.topics')
            self.graph.discover()
            self._timers += [node.create_timer(DISCOVERY_S, self.graph.discover, clock=steady),
                             node.create_timer(DRAIN_PERIOD_S, self.graph.drain, clock=steady)]

    def write(self, name: str, data: bytes, stamp_ns: int) -> None:
        """Send one published message (CDR bytes) to the viewers subscribed to ``name``.

        A topic served from the middleware is skipped: the node's messages on it come
        through the middleware like the others'.
        """
        if self.graph is not None and self.graph.subscriptions.get(name) is not None:
            return
        if name in self._unadvertised:
            self.view.add_topic(name, self._unadvertised.pop(name))
        self.view.write(name, data, stamp_ns)

    # ---- from the server's thread ---------------------------------------------------------
    def _on_node_thread(self, fn):
        """Run ``fn()`` on the node's thread; return its result or raise its exception."""
        done, answer = threading.Event(), []

        def call():
            try:
                answer.append((fn(), None))
            except Exception as exc:   # noqa: BLE001 - raised again in the caller's thread
                answer.append((None, exc))
            done.set()

        self._calls.put(call)
        if not done.wait(SERVICE_TIMEOUT_S):
            raise TimeoutError(f'the node did not answer within {SERVICE_TIMEOUT_S:g} s')
        result, error = answer[0]
        if error is not None:
            raise error
        return result

    def _service(self, cls, callback):
        def handle(payload: bytes) -> bytes:
            why = message_problem(payload, cls.Request)
            if why:
                raise ValueError(f'request refused: {why}')
            request = deserialize_message(payload, cls.Request)
            response = self._on_node_thread(lambda: callback(request, cls.Response()))
            return serialize_message(response)
        return handle

    def get(self, names: list) -> list:
        """Return [(name, value)] of the node's parameters ``names`` (all for none)."""
        return self._on_node_thread(lambda: self.parameters.values(names))

    def set(self, wanted: list) -> list:
        """Set the node's parameters [(name, value)]; return the values then in force."""
        return self._on_node_thread(lambda: self.parameters.set(wanted))

    def check_client_message(self, topic: str, schema_name: str, data: bytes) -> str:
        """Return why a viewer's message may not be published ('' when it may).

        Taken: a command topic's std_msgs/msg/Float64 whose payload is exactly one.
        """
        try:
            name = self.node.resolve_topic_name(topic)
            kind = msgdefs.normalize_type(schema_name)
        except Exception:   # noqa: BLE001 - any bad name is refused below
            name, kind = topic, schema_name
        if name not in self._command_topics or kind != COMMAND_TYPE:
            why = (f'only {", ".join(sorted(self._command_topics))} [{COMMAND_TYPE}] are taken '
                   'from a viewer')
        else:
            why = message_problem(data, Float64)
        if why and (name, kind, why) not in self._refused:
            self._refused.add((name, kind, why))
            self.node.get_logger().warning(
                f'live view: not publishing {topic} [{schema_name}] from a viewer: {why}')
        return why

    def _client_message(self, topic: str, schema_name: str, data: bytes) -> None:
        if self.check_client_message(topic, schema_name, data):
            return   # the server asked already; refused twice over
        self._calls.put(lambda: self._publish(topic, data))

    # ---- on the node's thread ---------------------------------------------------------------
    def _carry_out(self) -> None:
        """Carry out what the viewers asked since the last time."""
        while True:
            try:
                call = self._calls.get_nowait()
            except queue.Empty:
                return
            call()

    def _publish(self, topic: str, data: bytes) -> None:
        """Publish a viewer's command (checked) on its ROS topic."""
        name = self.node.resolve_topic_name(topic)
        if name not in self._command_pubs:
            self._command_pubs[name] = self.node.create_publisher(Float64, name, 10)
        try:
            self._command_pubs[name].publish(data)
        except RuntimeError as exc:   # rcl's error: checked above, refused all the same
            self.node.get_logger().error(f'live view: {topic} not published: {exc}')

    def close(self) -> None:
        """Stop the server and the subscriptions; calls still queued are dropped."""
        for timer in self._timers:
            self.node.destroy_timer(timer)
        self._timers = []
        if self.graph is not None:
            self.graph.destroy()
            self.graph = None
        self.view.close()


class ViewerParameters:
    """The node's parameters as the viewer names them: ``/abb_simulator.real_time_factor``.

    As foxglove_bridge names them. A value is set as ``ros2 param set`` sets it (validated
    as a whole, applied at the next step; a refusal is logged and the old value stays); a
    number is taken as the parameter's declared type (the app sends 2 for 2.0).
    """

    def __init__(self, node):
        self.node = node
        self.prefix = node.get_fully_qualified_name() + '.'

    def _short(self, name: str) -> str | None:
        short = name[len(self.prefix):] if name.startswith(self.prefix) else None
        return short if short and self.node.has_parameter(short) else None

    def values(self, names: list) -> list:
        """Return [(name, value)] of ``names`` that are the node's (every one for none)."""
        shorts = ([self._short(n) for n in names] if names
                  else sorted(self.node.list_parameters([], 0).names))
        return [(self.prefix + s, _plain(self.node.get_parameter(s).value))
                for s in shorts if s is not None]

    def set(self, wanted: list) -> list:
        """Set [(name, value)]; return the values of those names then in force."""
        from rclpy.parameter import Parameter
        params = []
        for name, value in wanted:
            short = self._short(name)
            if short is None:
                continue
            kind = self.node.get_parameter(short).type_
            try:
                params.append(Parameter(short, kind, _as_type(kind, value)))
            except (TypeError, ValueError):
                params.append(Parameter(short, value=value))   # refused below, with reason
        for param, result in zip(params, self.node.set_parameters(params)):
            if not result.successful:
                self.node.get_logger().warning(
                    f'live view: {param.name} not set: {result.reason}')
        return self.values([name for name, _ in wanted])


def _as_type(kind, value):
    """Return ``value`` as parameter type ``kind`` wants a number (int -> float for doubles)."""
    from rclpy.parameter import Parameter
    if kind == Parameter.Type.DOUBLE and not isinstance(value, bool):
        return float(value)
    if kind == Parameter.Type.DOUBLE_ARRAY:
        return [float(v) for v in value]
    return value


def _plain(value):
    """Return a parameter value as plain Python (arrays as lists)."""
    return value if isinstance(value, (bool, int, float, str)) or value is None else list(value)


def message_problem(data: bytes, cls) -> str:
    """Return why ``data`` is not exactly one CDR-encoded message of class ``cls`` ('').

    A message is a CDR encapsulation header (plain CDR, either byte order) and the fields;
    one that does not decode, or with bytes left over after it, is refused (the middleware
    refuses a payload of the wrong size when it is published, so the check comes first).
    """
    kind = msgdefs.type_name_of(cls())
    if len(data) < 4 or data[0] != 0 or data[1] not in (0, 1):
        return f'{len(data)} bytes that do not start with a CDR header: not a {kind}'
    try:
        message = deserialize_message(data, cls)
    except Exception as exc:   # noqa: BLE001 - whatever the decoder says
        return f'{len(data)} bytes that do not decode as a {kind} ({exc})'
    size = len(serialize_message(message))
    if len(data) != size:
        return f'{len(data)} bytes where a {kind} of these values has {size}'
    return ''


def _srv_type(cls) -> str:
    """Return the ROS type name of a generated service class: std_srvs/srv/SetBool."""
    return f'{cls.__module__.split(".")[0]}/srv/{cls.__name__}'


def start(node, services: dict, served: dict) -> SimulatorLiveView | None:
    """Start the live view the parameters ``live_view.*`` of ``node`` ask for (None: off).

    ``services`` and ``served`` as for :class:`SimulatorLiveView`.

    Raises ParamError naming ``live_view.host`` for a host that is empty (it would listen on
    every interface), does not resolve or is no address of this machine, and naming
    ``live_view.port`` when the server cannot listen on that port.
    """
    if not node.get_parameter('live_view.enabled').value:
        return None
    host = node.get_parameter('live_view.host').value
    port = node.get_parameter('live_view.port').value
    others = node.get_parameter('live_view.topics').value
    origins = node.get_parameter('live_view.allowed_origins').value
    max_rate = node.get_parameter('live_view.max_rate_hz').value
    try:
        live = SimulatorLiveView(node, host, port, services, served, others, origins,
                                 max_rate)
    except LiveViewError as exc:
        if exc.part == 'host':
            raise ParamError('live_view.host', host, HOST_VALID, exc.reason) from None
        raise ParamError('live_view.port', port, 'a port free on live_view.host',
                         str(exc)) from None
    node.get_logger().info(f'live view on {live.view.url} (Foxglove app or Lichtblick: Open '
                           'connection, Foxglove WebSocket)')
    return live


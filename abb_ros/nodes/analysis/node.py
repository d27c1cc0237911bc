"""``ros2 run abb_ros analysis``: predicted stability at the running speed (node abb_analysis).

Tells a controller, before the balls show it, whether the current operating point can be
balanced. A thin rclpy adapter over :mod:`abb_ros.model.stability.speed_bands`:

* parameters ``drive.*`` are declared exactly as the simulator declares them (one spec,
  :mod:`abb_ros.model.parameters.drive_spec`), so both load the same YAML; at start-up and whenever
  the simulator (parameter ``simulator_node``, resolved in this node's namespace) declares or
  changes ``drive.*`` or ``max_spindle_speed``, the values are copied into this node's own
  parameters (from ``/parameter_events``, and once by GetParameters for a simulator that was
  already running). The ball count follows ``joint_states`` (a changed ``drive.n`` applies in
  the simulator only on ``~/reset``).
* a worker thread computes the |lambda|max-vs-speed table over 0..max_spindle_speed whenever
  the parameters change (about 0.3 s for 300 speeds), and refines the current point exactly
  when it is idle; the executor only interpolates, so it never waits on a computation.
* the latest ``joint_states_throttle`` (the simulator's ``joint_states`` at
  ``joint_states_throttle_hz``, 50 Hz by default: the velocity of joint ``spindle`` = omega)
  updates the verdict at ``publish_rate_hz``: it is taken from a depth-1 best-effort
  subscription (:mod:`abb_ros.nodes.ros.taps`) by the publishing timer and read from its CDR bytes
  (:mod:`abb_ros.io.wire.joint_speed`). Reading the 1 kHz ``joint_states`` would cost the
  simulator's process about 30 us per message for this reader alone
  (docs/time_under_load.md).
  The verdict is published at most at ``publish_rate_hz`` and at least every ``heartbeat_s``:
  ``stability/margin`` (Float64, 1 - max of the in- and out-of-plane |lambda|max; -inf while
  no balanced equilibrium exists) and ``/diagnostics`` (status ``<node>: stability``). The
  level rule is in speed_bands. For n >= 3 balls the balanced equilibria form a family: the
  table is that of the symmetric fan, and once the balls are near balance (the residual of
  Eq. 26 at their ``joint_states`` angles below ``speed_bands.NEAR_BALANCE``) the exact point
  evaluates the member nearest them; ``/diagnostics`` says which (``family_member``,
  ``phi_star_deg``, ``neutral_modes_removed``). Until the first verdict the status is STALE
  and says why (table being computed, kernels compiled on a first start, no
  joint_states_throttle yet);
  ``stability/margin`` is published from the first verdict on.
"""

from __future__ import annotations

import math
import operator
import struct
import time

from rcl_interfaces.msg import ParameterEvent, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_parameter_events
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from abb_ros.io.wire import cdr, ros_messages
from abb_ros.io.wire.joint_speed import JointSpeedReader
from abb_ros.io.wire.topics import DIAGNOSTICS, JOINT_STATES_THROTTLE, STABILITY_MARGIN
from abb_ros.model.parameters.param_spec import DRIVE_PREFIX
from abb_ros.model.parameters.params import DriveParams, ParamError
from abb_ros.model.stability import speed_bands
from abb_ros.nodes.analysis.table import REFINE_TOL_RAD_S, TableWorker
from abb_ros.nodes.ros import ros_params
from abb_ros.nodes.ros.entry_point import run_node
from abb_ros.nodes.ros.parameter_table import specs_for
from abb_ros.nodes.ros.taps import Taps

NODE_NAME = 'abb_analysis'
QOS_DEPTH = 10
SYNC_PERIOD_S = 1.0
WARN_THROTTLE_S = 5.0
_STAMP = struct.Struct('<iI')

PARAMS = specs_for('analysis')
"""{ROS name: spec}: drive.* and max_spindle_speed as the simulator has them, then this
node's own (abb_ros/nodes/analysis/params.py)."""
DRIVE_NAMES = tuple(name for name in PARAMS if name.startswith(DRIVE_PREFIX))
FOLLOWED = DRIVE_NAMES + ('max_spindle_speed',)
"""Simulator parameters this node copies."""


def declare_parameters(node: Node) -> None:
    """Declare PARAMS (start-up values checked, int -> double accepted; ParamError)."""
    ros_params.declare(node, PARAMS)
    ros_params.coerce_on_set(node, PARAMS)


def config_from(values: dict) -> tuple[DriveParams, float, int]:
    """(drive, max_spindle_speed [rad/s], table_points) from {ROS name: value}; ParamError."""
    drive = DriveParams.from_mapping({k[len(DRIVE_PREFIX):]: v
                                      for k, v in values.items() if k in DRIVE_NAMES})
    omega_max = values['max_spindle_speed']
    if not (math.isfinite(omega_max) and omega_max > 0):
        raise ParamError('max_spindle_speed', omega_max, '(0, inf) rad/s',
                         'the analysis needs a speed range')
    return drive, float(omega_max), int(values['table_points'])


class AnalysisNode(Node):
    """The stability analysis node (see the module docstring)."""

    def __init__(self, **kwargs):
        super().__init__(NODE_NAME, **kwargs)
        declare_parameters(self)
        self.drive, self.omega_max, self.points = config_from(self._values())
        self.add_on_set_parameters_callback(self._validate)
        self.add_post_set_parameters_callback(self._on_parameters_set)

        self.sim_fqn = _resolve(self.get_parameter('simulator_node').value,
                                self.get_namespace())
        self.parameters_from = 'own parameters (simulator not seen yet)'
        self.sync_error = ''
        self.speed = None          # (omega [rad/s], header stamp [ns]) of the last joint_states
        self._read_speed = JointSpeedReader()
        self.n_seen = None
        self._dirty = False
        self._last_pub = 0.0
        self.status_count = 0
        self._status_key = ((), None)   # the inputs of the status encoded last (_inputs)
        self._status = (None, b'')      # its margin and status bytes (publish_status)
        self.worker = TableWorker()
        self._request_table()

        self._margin_pub = self.create_publisher(Float64, STABILITY_MARGIN, QOS_DEPTH)
        self._diag_pub = self.create_publisher(ros_messages.TOPIC_TYPES[DIAGNOSTICS],
                                               DIAGNOSTICS, QOS_DEPTH)
        self._taps = Taps(self)
        self._joint_states = self._taps.subscribe(
            JointState, JOINT_STATES_THROTTLE, QoSProfile(depth=1,
                                                   reliability=ReliabilityPolicy.BEST_EFFORT))
        self.create_subscription(ParameterEvent, '/parameter_events', self._on_parameter_event,
                                 qos_profile_parameter_events)
        self._param_client = AsyncParameterClient(self, self.sim_fqn)
        self._sync_future = None
        self._sync_timer = self.create_timer(SYNC_PERIOD_S, self._sync_from_simulator)
        self._timer = self.create_timer(1.0 / self.get_parameter('publish_rate_hz').value,
                                        self._on_timer)
        self.get_logger().info(
            f'following {self.sim_fqn}; speed range 0-{self.omega_max:g} rad/s, '
            f'{self.points} table points')

    # ---- parameters ----------------------------------------------------------------------
    def _values(self) -> dict:
        return {name: self.get_parameter(name).value
                for name in FOLLOWED + ('table_points',)}

    def _validate(self, parameters) -> SetParametersResult:
        return ros_params.validate_merged(self._values(), parameters, config_from)

    def _on_parameters_set(self, parameters) -> None:
        names = {p.name for p in parameters}
        if names & set(FOLLOWED + ('table_points',)):
            config = config_from(self._values())
            if config != (self.drive, self.omega_max, self.points):
                self.drive, self.omega_max, self.points = config
                self._request_table()
        if 'publish_rate_hz' in names:
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(1.0 / self.get_parameter('publish_rate_hz').value,
                                            self._on_timer)
        self._dirty = True

    def _effective_drive(self) -> DriveParams:
        """Return the drive as the simulator runs it: n from joint_states once seen.

        joint_states carry race 1's balls then race 2's: n is what race2.n leaves of them.
        """
        if self.n_seen is not None and self.n_seen != self.drive.n_balls:
            return self.drive.replace(n=max(self.n_seen - self.drive.race2_n, 0))
        return self.drive

    def _request_table(self) -> None:
        self.worker.request((self._effective_drive(), self.omega_max, self.points))

    def _adopt(self, values: dict, source: str) -> None:
        """Copy the simulator's parameter values into this node's own (validated here too)."""
        params = [Parameter(name, value=v) for name, v in values.items()
                  if name in FOLLOWED and v is not None]
        if not params:
            return
        result = self.set_parameters_atomically(params)
        self.parameters_from = self.sim_fqn
        if result.successful:
            self.sync_error = ''
        else:
            self.sync_error = f'parameters of {self.sim_fqn} refused here ({source}): ' \
                              f'{result.reason}'
            self.get_logger().error(self.sync_error)
        self._dirty = True

    def _on_parameter_event(self, event: ParameterEvent) -> None:
        if event.node != self.sim_fqn:
            return
        values = {p.name: parameter_value_to_python(p.value)
                  for p in list(event.new_parameters) + list(event.changed_parameters)}
        self._adopt(values, 'parameter event')

    def _sync_from_simulator(self) -> None:
        """Once: read the followed parameters of an already running simulator."""
        if self._sync_future is not None or not self._param_client.services_are_ready():
            return
        self._sync_future = self._param_client.get_parameters(list(FOLLOWED))
        self._sync_future.add_done_callback(self._on_sync)

    def _on_sync(self, future) -> None:
        self.destroy_timer(self._sync_timer)
        try:
            response = future.result()
        except Exception as err:  # noqa: BLE001 - a lost service call: retry by events
            self.get_logger().warning(f'could not read the parameters of {self.sim_fqn}: {err}')
            return
        values = {name: parameter_value_to_python(v)
                  for name, v in zip(FOLLOWED, response.values) if v.type != 0}
        self._adopt(values, 'GetParameters')

    # ---- inputs and publishing -------------------------------------------------------------
    def _on_joint_states(self, data: bytes) -> None:
        try:
            js = self._read_speed(data)
        except ValueError as err:
            self.get_logger().warning(f'malformed joint_states: {err}',
                                      throttle_duration_sec=WARN_THROTTLE_S)
            return
        omega = js.omega
        if not math.isfinite(omega):
            self.get_logger().warning(f'joint_states without a finite spindle speed: {omega!r}',
                                      throttle_duration_sec=WARN_THROTTLE_S)
        if js.named and js.n != self.n_seen:
            self.n_seen = js.n
            self._request_table()
        self.speed = (omega, js.stamp_ns)
        self._dirty = True
        if math.isfinite(omega) and omega > 0:
            self.worker.want(omega, speed_bands.member_near_balls(self._effective_drive(),
                                                                  js.phi))

    def _on_timer(self) -> None:
        latest = None
        while (taken := Taps.take(self._joint_states)) is not None:
            latest = taken
        if latest is not None:
            self._on_joint_states(latest[0])
        if self._dirty or time.monotonic() - self._last_pub >= \
                self.get_parameter('heartbeat_s').value:
            self.publish_status()

    def _inputs(self) -> tuple[tuple, tuple]:
        """Return what the status depends on, read once: (objects, plain values).

        The objects (the worker's table and exact point, the drive) are compared by identity,
        the plain values by equality: equal inputs give the same status.
        """
        worker = self.worker
        return ((worker.table, worker.exact, self.drive),
                (worker.error, worker.busy, self.speed[0] if self.speed else None,
                 self.n_seen, self.omega_max, self.sync_error, self.parameters_from))

    def assessment(self) -> speed_bands.Assessment:
        """Return the current verdict (never raises)."""
        return self._assess(self._inputs())

    def _assess(self, inputs) -> speed_bands.Assessment:
        """Return the verdict of ``inputs`` (:meth:`_inputs`)."""
        (table, exact, _), (error, busy, omega, *_) = inputs
        if error:
            return speed_bands.Assessment(speed_bands.ERROR, error, math.nan, {'omega': omega})
        if table is None or table.params != self._effective_drive() \
                or table.omega_max != self.omega_max or busy:
            why = 'computing the stability table for the current parameters'
            if table is None:
                why = f'no verdict yet: {why} (a first start also compiles the kernels, ' \
                      'unless python -m abb_ros.model.warmup has)'
            return speed_bands.Assessment(speed_bands.STALE, why, math.nan, {'omega': omega})
        if omega is None:
            a = speed_bands.assess(table, 0.0)
            return speed_bands.Assessment(speed_bands.STALE, 'no joint_states_throttle yet '
                                          '(spindle speed unknown); ' + _first_clause(a.message),
                                          math.nan, a.values)
        if exact is not None and abs(exact.omega - omega) > REFINE_TOL_RAD_S:
            exact = None
        return speed_bands.assess(table, omega, exact)

    def publish_status(self) -> None:
        """Publish the margin and the stability status on /diagnostics.

        Both are encoded once per distinct status (:meth:`_inputs`): at a steady speed only
        the header stamp of the status changes from one to the next.
        """
        inputs = self._inputs()
        objects, plain = self._status_key
        if not (plain == inputs[1] and all(map(operator.is_, objects, inputs[0]))):
            self._status = self._encode_status(inputs)
            self._status_key = inputs
        margin, status = self._status
        if margin is not None:
            self._margin_pub.publish(margin)
        stamp_ns = self.speed[1] if self.speed else self.get_clock().now().nanoseconds
        self._diag_pub.publish(restamped(status, stamp_ns))
        self._last_pub = time.monotonic()
        self._dirty = False
        self.status_count += 1

    def _encode_status(self, inputs) -> tuple[bytes | None, bytes]:
        """Return the CDR bytes of the margin (None: no verdict) and of the status (stamp 0)."""
        a = self._assess(inputs)
        level, message = a.level, a.message
        if self.sync_error:
            level, message = speed_bands.ERROR, f'{self.sync_error}; {message}'
        if self.n_seen is not None and self.n_seen != self.drive.n_balls:
            message += f' (n = {self.n_seen} from joint_states; drive.n = {self.drive.n} ' \
                       'applies on the simulator\'s ~/reset)'
        values = dict(a.values, parameters_from=self.parameters_from)
        if self.drive.beyond_paper:      # terms the paper's linear analysis ignores
            values['ignored_by_linear_analysis'] = ', '.join(self.drive.beyond_paper)
        margin = None if math.isnan(a.margin) else cdr.float64(0, 0, a.margin)
        return margin, cdr.diagnostics(0, f'{self.get_fully_qualified_name()}: stability',
                                       bytes([level]), message, values)

    def destroy_node(self):
        """Stop the table worker and the raw subscriptions, then destroy the node."""
        self.worker.stop()
        self._taps.destroy()
        return super().destroy_node()


def restamped(status: bytes, stamp_ns: int) -> bytes:
    """Return the CDR bytes of a DiagnosticArray ``status`` with its header stamp ``stamp_ns``.

    The stamp (int32 sec, uint32 nanosec) is the first field after the encapsulation.
    """
    return status[:4] + _STAMP.pack(*divmod(stamp_ns, 1_000_000_000)) + status[12:]


def _first_clause(text: str) -> str:
    return text.split(';')[0]


def _resolve(name: str, namespace: str) -> str:
    """Fully qualified node name of ``name`` relative to ``namespace``."""
    if name.startswith('/'):
        return name
    return namespace.rstrip('/') + '/' + name


def main(args=None):
    """Run the analysis node until SIGINT/SIGTERM; return the exit code."""
    return run_node(NODE_NAME, AnalysisNode, args, kind='analysis')


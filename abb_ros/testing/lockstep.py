"""A plant stepped in lockstep with the controller under test, for deterministic tests.

:class:`LockstepPlant` runs the real simulator node (:class:`abb_ros.nodes.simulator.
SimulatorNode`) in this process with its own rclpy Context, started paused with
real_time_factor 0 (simulated time: stamps start at 0 and it publishes ``/clock``). Nodes under
test join the same Context (``add_node``) or run in other processes; everything talks over DDS.
:meth:`LockstepPlant.advance` advances the plant exactly N publish periods, each one:

1. a ``~/step`` service call (over DDS): the plant integrates one period and publishes it;
2. the executor spins the nodes until the plant has received ``answers`` commands on
   ``spindle/speed_cmd`` or (torque mode) ``spindle/current_cmd`` since the step (its
   accepted + refused counters, read in process) and the harness has the period's
   ``joint_states``.

So every command is applied at a known step boundary, whatever the scheduling: the same
parameters, seed and controller give byte-identical topics run after run. A controller must
therefore answer each ``joint_states`` with exactly ``answers`` commands (default 1 when a
node added with ``add_node`` publishes one of them, else 0); a controller in another
process: pass ``answers=1``. Waits have a deadline; a miss raises :class:`LockstepTimeout`
("timed out after ...").

The analysis node (``analysis=True``) runs in the same executor; its ``stability/margin`` is
paced by the wall clock, so a controller that wants byte-identical runs must not let it
decide a command (the example controller decides from the band table computed in process).
"""

from __future__ import annotations

import math
import time

import numpy as np

from abb_ros.io.wire.topics import (
    CURRENT_CMD,
    DECK_POSE,
    JOINT_STATES,
    SPEED_CMD,
    STABILITY_MARGIN,
)
from abb_ros.model.dynamics.state import rbar
from abb_ros.model.parameters.params import PARAM_SPECS, DriveParams
from abb_ros.model.parameters.plant_spec import MOTOR_DEFAULTS

__all__ = ['LockstepPlant', 'LockstepTimeout', 'Trace', 'drive_parameters', 'DEADLINE_S']

DEADLINE_S = 30.0
"""Longest wait for one period (step reply, the controller's answers, the harness' data)."""
DEFAULT_RATE_HZ = 200
"""Publish (and control) rate of a lockstep plant unless given: 50 RK4 steps per period."""


class LockstepTimeout(AssertionError):
    """A lockstep wait missed its deadline."""


def drive_parameters(drive: DriveParams) -> dict:
    """Return ``{'drive.<name>': value}`` for each field of ``drive`` (as parameter overrides)."""
    return {f'drive.{name}': value for name, value in drive.as_dict().items()}


class Trace:
    """What the harness saw of the plant, one row per publish period.

    ``t`` [s] (header stamps), ``omega`` [rad/s], ``phi`` [rad] shape (K, n), ``rbar`` []
    (deck/pose position over R), ``omega_cmd`` [rad/s] and ``current_cmd`` [A] (the commands
    in force after the period's answer).
    """

    def __init__(self, states, poses, commands, R: float, currents=()):
        by_stamp = {_stamp_ns(m): m for m in poses}
        rows = [(s, by_stamp.get(_stamp_ns(s))) for s in states]
        self.t = np.array([_stamp_ns(s) * 1e-9 for s, _ in rows])
        self.omega = np.array([s.velocity[0] for s, _ in rows])
        self.phi = np.array([list(s.position[1:]) for s, _ in rows]).reshape(len(rows), -1)
        self.rbar = np.array([math.nan if p is None else rbar(
            p.pose.position.x, p.pose.position.y, p.pose.position.z, R) for _, p in rows])
        self.omega_cmd = np.array(commands[:len(rows)] + [math.nan] * (len(rows)
                                                                        - len(commands)))
        self.current_cmd = np.array(list(currents)[:len(rows)] + [math.nan] * (
            len(rows) - len(currents)))

    def __len__(self) -> int:
        return self.t.size


class LockstepPlant:
    """The simulator node paused in this process, advanced period by period (module doc).

    ``parameters``: simulator parameter overrides ({ROS name: value}); the harness adds
    real_time_factor 0, start_paused true and, unless given, publish_rate_hz = imu.rate_hz =
    :data:`DEFAULT_RATE_HZ`. ``namespace``: of the plant, the analysis and the harness node
    (give user nodes the same). ``analysis``: also run the analysis node (stability/margin).
    """

    def __init__(self, parameters: dict | None = None, *, namespace: str = '',
                 analysis: bool = False, deadline_s: float = DEADLINE_S):
        import rclpy
        from geometry_msgs.msg import PoseStamped
        from rclpy.node import Node
        from rclpy.parameter import Parameter
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_srvs.srv import Trigger

        from abb_ros.nodes.simulator.node import SimulatorNode, make_executor

        self._qos = QoSProfile(history=HistoryPolicy.KEEP_ALL,
                               reliability=ReliabilityPolicy.RELIABLE)
        self._Trigger = Trigger
        self.deadline_s = deadline_s
        values = {'publish_rate_hz': DEFAULT_RATE_HZ, 'imu.rate_hz': DEFAULT_RATE_HZ}
        values.update(parameters or {})
        values.update(real_time_factor=0.0, start_paused=True)
        self.parameters = values
        self.namespace = namespace
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.executor = make_executor(self.context)
        ns = namespace or None
        overrides = [Parameter(k, value=v) for k, v in values.items()]
        # The plant first: its start-up sample goes out before anyone listens, in every run.
        try:
            self.sim = SimulatorNode(context=self.context, namespace=ns,
                                     parameter_overrides=overrides)
        except Exception:  # e.g. ParamError: invalid parameters; leave no Context behind
            rclpy.try_shutdown(context=self.context)
            raise
        self._nodes = [self.sim]
        self.analysis = None
        if analysis:
            from abb_ros.nodes.analysis.node import AnalysisNode
            followed = [p for p in overrides if p.name.startswith('drive.')
                        or p.name == 'max_spindle_speed']
            self.analysis = AnalysisNode(context=self.context, namespace=ns,
                                         parameter_overrides=followed)
            self._nodes.append(self.analysis)
        self.node = Node('lockstep_harness', context=self.context, namespace=ns)
        self._nodes.append(self.node)
        for n in self._nodes:
            self.executor.add_node(n)
        self._step_client = self.node.create_client(
            Trigger, f'{self.sim.get_fully_qualified_name()}/step')
        self._states = self.record(JOINT_STATES, JointState)
        self._poses = self.record(DECK_POSE, PoseStamped)
        self._commands = []
        self._cmd_seen = self.record(SPEED_CMD)
        self._current_seen = self.record(CURRENT_CMD)
        self._currents = []
        self._command_pub = None
        self._explicit_answers = None
        self._connected = False
        self.periods = 0

    # ---- set-up --------------------------------------------------------------------------
    def add_node(self, node) -> None:
        """Spin ``node`` (created with ``context=plant.context``) with the plant."""
        self._nodes.append(node)
        self.executor.add_node(node)
        self._connected = False

    def record(self, topic: str, kind=None, raw: bool = False) -> list:
        """Return a list that collects every message of ``topic``.

        Relative names resolve in the plant's namespace; ``raw``: the CDR bytes. ``kind``
        defaults to the type of a bench topic (the simulator's, ``spindle/speed_cmd``,
        ``stability/margin``).
        """
        from std_msgs.msg import Float64

        from abb_ros.io.wire import ros_messages
        got = []
        kind = kind or ros_messages.TOPIC_TYPES.get(topic) or (
            Float64 if topic in (SPEED_CMD, CURRENT_CMD, STABILITY_MARGIN) else None)
        if kind is None:
            raise ValueError(f'record({topic!r}): give the message type (kind=...)')
        self.node.create_subscription(kind, topic, got.append, self._qos, raw=raw)
        return got

    @property
    def answers(self) -> int:
        """Commands the plant waits for after each period (see the module doc)."""
        if self._explicit_answers is not None:
            return self._explicit_answers
        cmd = {self.node.resolve_topic_name(t) for t in (SPEED_CMD, CURRENT_CMD)}
        return int(any(p.topic_name in cmd for n in self._nodes[1:] if n is not self.node
                       for p in n.publishers))

    @answers.setter
    def answers(self, value: int) -> None:
        self._explicit_answers = int(value)

    def shared_parameters(self) -> list:
        """Return the plant's ``drive.*``, ``motor.*`` and ``max_spindle_speed`` parameters.

        As rclpy Parameters: the ``parameter_overrides`` that give a node under test the plant's
        drive.
        """
        return self.sim.get_parameters([f'drive.{name}' for name in PARAM_SPECS]
                                       + [f'motor.{name}' for name in MOTOR_DEFAULTS]
                                       + ['max_spindle_speed'])

    def bands(self) -> tuple:
        """Return the unbalanced speed bands of the plant's drive.

        The analysis' table: speed_bands.speed_table over 0..max_spindle_speed.
        """
        from abb_ros.model.stability.speed_bands import speed_table
        return speed_table(self.drive, self.sim.settings.max_spindle_speed).bands

    @property
    def drive(self) -> DriveParams:
        """The plant's drive parameters (SI)."""
        return self.sim.drive

    @property
    def period_s(self) -> float:
        """The plant's publish period [s] (simulated time)."""
        return self.sim.sampler.publish_every * self.sim.settings.dt_ns * 1e-9

    # ---- lockstep ------------------------------------------------------------------------
    def advance(self, periods: int = 1) -> None:
        """Advance exactly ``periods`` publish periods (module doc)."""
        if not self._connected:
            self._wait_connected()
            self._connected = True
        answers = self.answers
        for _ in range(int(periods)):
            before = self._received()
            future = self._step_client.call_async(self._Trigger.Request())
            self.spin_until(future.done, 'the ~/step reply')
            reply = future.result()
            if not reply.success:
                raise RuntimeError(f'~/step refused: {reply.message}')
            self.periods += 1
            target = self.periods
            self.spin_until(lambda: self._received() >= before + answers
                       and len(self._cmd_seen) + len(self._current_seen) >= self._received()
                       and len(self._states) >= target,
                       f'period {target}: {answers} command(s) and joint_states')
            last = self._cmd_seen[-1].data if self._cmd_seen else self.sim.speed_cmd
            self._commands.append(last)
            self._currents.append(self._current_seen[-1].data if self._current_seen
                                  else self.sim.current_cmd)

    def run_for(self, seconds: float) -> None:
        """Advance round(seconds / period) periods."""
        self.advance(round(seconds / self.period_s))

    def command(self, omega: float) -> None:
        """Publish a spindle speed command [rad/s] from the harness.

        Returns when the plant has it (applied from the next period on).
        """
        from std_msgs.msg import Float64
        if self._command_pub is None:
            self._command_pub = self.node.create_publisher(Float64, SPEED_CMD, self._qos)
            self.spin_until(lambda: self._command_pub.get_subscription_count() >= 1,
                       f'the plant subscribing to {SPEED_CMD}')
        before = self._received()
        self._command_pub.publish(Float64(data=float(omega)))
        self.spin_until(lambda: self._received() > before, 'the plant receiving the command')

    def trace(self) -> Trace:
        """Return the periods so far (see :class:`Trace`)."""
        return Trace(self._states, self._poses, self._commands, self.drive.R, self._currents)

    def spin_until_idle(self, quiet_s: float = 0.05) -> None:
        """Spin until no callback ran for ``quiet_s`` (late subscribers catch up)."""
        end = time.monotonic() + quiet_s
        deadline = time.monotonic() + self.deadline_s
        while time.monotonic() < end and time.monotonic() < deadline:
            total = self._activity()
            self.executor.spin_once(timeout_sec=quiet_s / 5)
            if self._activity() != total:
                end = time.monotonic() + quiet_s

    def close(self) -> None:
        """Destroy the nodes and the Context (a second call does nothing)."""
        import rclpy
        if not self._nodes:
            return
        self.executor.shutdown()
        for n in reversed(self._nodes):
            n.destroy_node()
        self._nodes = []
        rclpy.try_shutdown(context=self.context)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ---- internals -----------------------------------------------------------------------
    def _received(self) -> int:
        c = self.sim.counters
        return c['commands_accepted'] + c['commands_refused']

    def _activity(self) -> int:
        return (self._received() + len(self._states) + len(self._poses) + len(self._cmd_seen)
                + len(self._current_seen))

    def spin_until(self, predicate, what: str) -> None:
        """Spin the nodes until ``predicate()``; LockstepTimeout after the deadline."""
        deadline = time.monotonic() + self.deadline_s
        while not predicate():
            if time.monotonic() > deadline:
                raise LockstepTimeout(f'timed out after {self.deadline_s:g} s waiting for {what}')
            self.executor.spin_once(timeout_sec=0.01)

    def _wait_connected(self) -> None:
        """Wait until the plant's ~/step service is up and the subscriptions are matched.

        Every subscription of a spinning node to a topic the plant publishes (or to the command
        topic) must be matched.
        """
        self.spin_until(self._step_client.service_is_ready, 'the plant\'s ~/step service')
        wanted = {}
        for n in self._nodes:
            for sub in n.subscriptions:
                wanted[sub.topic_name] = wanted.get(sub.topic_name, 0) + 1
        for pub in [p for n in self._nodes for p in n.publishers if p.topic_name in wanted]:
            need = wanted[pub.topic_name]
            self.spin_until(lambda pub=pub, need=need: pub.get_subscription_count() >= need,
                       f'{need} subscriber(s) of {pub.topic_name}')


def _stamp_ns(msg) -> int:
    s = msg.header.stamp
    return s.sec * 1_000_000_000 + s.nanosec

"""``ros2 run abb_ros simulator``: the drive as a fixed-rate plant over ROS 2 (node abb_simulator).

A thin rclpy adapter: :class:`abb_ros.model.integrate.Simulation` integrates, a
:class:`abb_ros.model.sampling.PlantSampler` decides when the state and the IMU are due,
:mod:`abb_ros.io.cdr` encodes the messages (the same encoder as the headless
``abb-sim run``). Topics, parameters and services: docs/ros_api.md.

Time: stamps are ``epoch + steps * dt`` in integer nanoseconds. With real_time_factor 1 at
start-up the epoch is the wall clock at start (rounded to a step), so stamps follow wall
time; otherwise the epoch is 0, the node publishes ``/clock`` and stamps are simulated
time (use_sim_time consumers follow). A steady-clock timer paces integration: each tick
integrates every publish period that is due by then (catching up when late, counted as
overruns); with real_time_factor 0 each tick integrates as many periods as fit in
``BATCH_WALL_S`` and the executor serves topics and services in between.

Under load (docs/time_under_load.md): the lag of each tick's first stamp behind its schedule
(the wall clock with wall-time stamps) is measured and reported in /diagnostics
(``stamp_lag``: WARN above one publish period). When it exceeds ``max_stamp_lag`` the plant
does not catch up: the missed periods are dropped (``slips``, ``slipped_time``, level ERROR);
wall-time stamps then jump forward to the wall clock as after a pause, simulated time (and
``/clock``) goes on from where it was.

Messages are published as CDR bytes from :mod:`abb_ros.io.cdr` (the headless run's encoder:
no rclpy message is built). ``record.path`` or ``~/start_recording`` / ``~/stop_recording``
write exactly those bytes to a bag in process (:class:`abb_ros.io.bag_writer.BagWriter`,
log time = stamp, as the headless run writes them).
"""

from __future__ import annotations

import math
import sys
import time

from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from abb_ros.io import cdr, ros_messages
from abb_ros.io.bag_writer import BagError, BagWriteError, BagWriter
from abb_ros.model.params import ParamError
from abb_ros.model.integrate import Simulation, StateError, initial_state
from abb_ros.model.sampling import PlantSampler
from abb_ros.model.sensors import ImuModel
from abb_ros.nodes import ros_params
from abb_ros.nodes.bench import BenchIO
from abb_ros.nodes.entry_point import make_executor, run_node, spin
from abb_ros.nodes.graph_recording import GraphRecording, resolve_topics
from abb_ros.nodes.rclpy_access import RCLError
from abb_ros.nodes.realtime import FifoScheduling
from abb_ros.nodes.recorder import DRAIN_PERIOD_S, default_output

NODE_NAME = 'abb_simulator'
QOS_DEPTH = 10
RECORD_DISCOVERY_S = 0.5
"""How often the graph is searched for the record.topics while recording [s]."""
PUBLISH_DEPTH = 1000
"""History of each published topic: a reliable subscriber (a recorder) that falls behind by up
to this many messages (1 s at 1 kHz) still gets every one."""
DIAGNOSTICS_PERIOD_S = 1.0
BATCH_WALL_S = 0.005
"""As fast as possible: wall time spent integrating per timer tick before yielding."""
WARN_THROTTLE_S = 1.0

__all__ = ['SimulatorNode', 'main', 'make_executor', 'spin']


class SimulatorNode(Node):
    """The ABB drive simulator node (see the module docstring)."""

    def __init__(self, **kwargs):
        super().__init__(NODE_NAME, **kwargs)
        self.drive, self.settings = ros_params.declare_all(self)
        s = self.settings
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._dt_ns = s.dt_ns
        self.sim = Simulation(self.drive, s.initial_speed, self._dt_ns * 1e-9,
                              spindle=s.spindle())
        self.imu = ImuModel(s.imu, seed=s.seed)
        self.sampler = PlantSampler(self.sim, self.imu, s.publish_every, s.imu_every)
        _warm_up(self.sim)
        self._epoch_ns = 0
        self._wall_time_base = s.real_time_factor == 1.0
        if self._wall_time_base:
            now = self.get_clock().now().nanoseconds
            self._epoch_ns = now - now % self._dt_ns
        self.pending_drive = self.drive
        self.fault = ''
        self.paused = s.start_paused
        self.counters = dict(overruns=0, slips=0, commands_accepted=0, commands_refused=0,
                             commands_saturated=0)
        self.slipped_ns = 0           # wall time dropped by slips [ns]
        self.lag_ns = 0               # largest stamp lag in the diagnostics window [ns]
        self.lag_max_ns = 0           # ... since start [ns]
        self._window_slips = 0
        self._run_wall_ns = 0         # wall time and steps while running, for the
        self._run_steps = 0           # real_time_factor since start
        self._max_lag_ns = _max_stamp_lag_ns(self)
        self.scheduling = FifoScheduling()   # of the thread that integrates (its timer's)
        self.published = dict.fromkeys(ros_messages.TOPIC_TYPES, 0)
        self.bag = None
        self.graph = None             # the other nodes' topics of the recording (record.topics)
        self._graph_timers = []       # its discovery and drain, made at its first start
        self.recording_error = ''
        self.speed_cmd = s.initial_speed
        self.current_cmd = 0.0
        if s.spindle_mode == 'torque':
            self.sim.set_command(0.0)
        self._params_changed = False

        self._pubs = {topic: self.create_publisher(kind, topic, PUBLISH_DEPTH)
                      for topic, kind in ros_messages.TOPIC_TYPES.items()}
        self._names = {topic: pub.topic_name for topic, pub in self._pubs.items()}
        self.bench = BenchIO(self, QOS_DEPTH)   # FG, faults, disturbances, markers
        self.create_subscription(Float64, 'spindle/speed_cmd', self._on_speed_cmd, QOS_DEPTH)
        self.create_subscription(Float64, 'spindle/current_cmd', self._on_current_cmd,
                                 QOS_DEPTH)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self.create_service(Trigger, '~/step', self._on_step)
        self.create_service(Trigger, '~/start_recording', self._on_start_recording)
        self.create_service(Trigger, '~/stop_recording', self._on_stop_recording)
        self.add_on_set_parameters_callback(lambda ps: ros_params.validate_change(self, ps))
        self.add_post_set_parameters_callback(self._on_parameters_set)

        resolve_topics(self, self.get_parameter('record.topics').value, 'record.topics')
        path = self.get_parameter('record.path').value
        if path:
            error = self.start_recording(path)
            if error:
                raise ParamError('record.path', path, 'a directory that does not exist yet, '
                                 'in a writable place', error)
        self._diag_window = (self._steady.now().nanoseconds, self.sim.steps, True)
        self._diag_timer = self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics,
                                             clock=self._steady)
        self.get_logger().info(
            f'n = {self.drive.n} balls, omega0 = {self.drive.omega0:.1f} rad/s, initial '
            f'{s.initial_speed:.1f} rad/s, {s.integration_rate_hz} Hz steps, publishing at '
            f'{s.publish_rate_hz} Hz, real_time_factor {s.real_time_factor:g}'
            + (', paused' if self.paused else ''))
        # Last: the pacing is anchored now (the first log line alone can take ~80 ms, which
        # the first tick would otherwise owe, or drop as a slip on a loaded machine).
        self._timer = None
        self._publish(self.sampler.sample_now())
        self._restart_pacing()

    # ---- time ---------------------------------------------------------------------------
    @property
    def owns_time(self) -> bool:
        """True when stamps are simulated time: then /clock is published."""
        return not (self._wall_time_base and self.settings.real_time_factor == 1.0)

    def stamp_ns(self, steps: int | None = None) -> int:
        return self._epoch_ns + (self.sim.steps if steps is None else steps) * self._dt_ns

    def _restart_pacing(self) -> None:
        """(Re)create the integration timer for the current mode, anchored now."""
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        rtf = self.settings.real_time_factor
        self._want_scheduling()
        if self.paused or self.fault:
            return
        if self._wall_time_base and rtf == 1.0:
            # After a pause the stamps jump forward to the wall clock again (never back).
            now = self.get_clock().now().nanoseconds
            lag = now - self.stamp_ns()
            if lag > 0:
                self._epoch_ns += lag - lag % self._dt_ns
        if rtf == 0.0:
            self._timer = self.create_timer(0.0, self._tick_fast, clock=self._steady)
        else:
            self._anchor_pacing(self.sim.steps)
            period_ns = self.sampler.publish_every * self._dt_ns
            self._timer = self.create_timer(period_ns / rtf * 1e-9, self._tick_paced,
                                            clock=self._steady)

    def _anchor_pacing(self, steps: int) -> None:
        """Pace from now at ``steps``. Ticks come at the publish period in wall time; the due
        step count is computed half a period ahead, so that ticks early or late by less than
        P/2 (timer wake-up jitter either way) integrate exactly one period each."""
        wall_period_ns = (self.sampler.publish_every * self._dt_ns
                          / self.settings.real_time_factor)
        self._anchor = (self._steady.now().nanoseconds - int(wall_period_ns / 2), steps)

    # ---- integration ---------------------------------------------------------------------
    def _tick_paced(self) -> None:
        self._apply_parameters()
        if self._timer is None:
            return
        if self.scheduling.pending:
            self._apply_scheduling()
        wall0, steps0 = self._anchor
        every = self.sampler.publish_every
        rtf = self.settings.real_time_factor
        elapsed = self._steady.now().nanoseconds - wall0
        due = steps0 + int(elapsed * rtf) // self._dt_ns
        periods = due // every - self.sim.steps // every
        if periods <= 0:
            return
        if periods > 1:
            self.counters['overruns'] += periods - 1
        first = (self.sim.steps // every + 1) * every      # step of this tick's first stamp
        lag_ns = self._lag_ns(first, due)
        if lag_ns > self._max_lag_ns and periods > 1:
            self._slip(periods - 1)
            periods = 1
            lag_ns = self._lag_ns(first, first)
        self.lag_ns = max(self.lag_ns, lag_ns)
        self.lag_max_ns = max(self.lag_max_ns, lag_ns)
        for _ in range(periods):
            if not self._integrate_period():
                return

    def _want_scheduling(self) -> None:
        """SCHED_FIFO at realtime_priority only while paced: a FIFO thread that never sleeps
        (real_time_factor 0) would hold a core."""
        paced = self.settings.real_time_factor > 0
        self.scheduling.want(self.get_parameter('realtime_priority').value if paced else 0)

    def _apply_scheduling(self) -> None:
        """Give this (the integrating) thread the wanted policy; a refusal is one warning."""
        warning = self.scheduling.apply()
        if warning:
            self.get_logger().warning(warning)
        elif self.scheduling.applied:
            self.get_logger().info(f'integrating under {self.scheduling.state}')

    def _lag_ns(self, step: int, due: int) -> int:
        """How late the stamp of ``step`` is published now [ns of wall time]: behind the wall
        clock with wall-time stamps, else behind the pacing schedule (``due``)."""
        if not self.owns_time:
            return time.time_ns() - self.stamp_ns(step)
        return int((due - step) * self._dt_ns / self.settings.real_time_factor)

    def _slip(self, periods: int) -> None:
        """Drop ``periods`` publish periods the plant could not keep up with: the pacing
        restarts from now; wall-time stamps jump forward by them (as after a pause)."""
        every = self.sampler.publish_every
        self.counters['slips'] += 1
        self._window_slips += 1
        dropped_ns = periods * every * self._dt_ns
        self.slipped_ns += int(dropped_ns / self.settings.real_time_factor)
        if not self.owns_time:
            self._epoch_ns += dropped_ns
        self._anchor_pacing((self.sim.steps // every + 1) * every)

    def _tick_fast(self) -> None:
        self._apply_parameters()
        if self._timer is None:
            return
        if self.scheduling.pending:
            self._apply_scheduling()
        end = time.perf_counter() + BATCH_WALL_S
        while time.perf_counter() < end:
            if not self._integrate_period():
                return

    def _integrate_period(self) -> bool:
        """Advance one publish period and publish what is due; False on a fault."""
        try:
            samples = self.sampler.next_period()
        except StateError as err:
            self._set_fault(str(err))
            return False
        for sample in samples:
            if not sample.is_finite():
                self._set_fault(f'non-finite output at t = {self.sim.t:.6f} s')
                return False
            self._publish(sample)
        return True

    def _publish(self, sample) -> None:
        if sample is None:
            return
        stamp_ns, encoded = cdr.sample_cdr(sample, self._dt_ns, self.imu.config,
                                           self._epoch_ns, self.owns_time)
        for topic, data in encoded:
            self._send(topic, data, stamp_ns)
        self.bench.on_sample(sample)

    def _send(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Publish the CDR bytes of one message (and record them when recording)."""
        try:
            self._pubs[topic].publish(data)
        except RCLError:
            if self.context.ok():
                raise
            return  # the context was shut down by its owner (tests): nothing to publish to
        self.published[topic] += 1
        if self.bag is not None:
            self._record(topic, data, stamp_ns)

    # ---- in-process recording ---------------------------------------------------------------
    def start_recording(self, path: str) -> str:
        """Record every message published from now on to a new bag at ``path``; returns ''
        or why not."""
        if self.bag is not None:
            return f'already recording to {self.bag.path}'
        try:
            bag = BagWriter(path)
            bag.set_drive_params(self.drive)
        except (BagError, OSError) as exc:
            return str(exc)
        self.bag, self.recording_error = bag, ''
        topics = self.get_parameter('record.topics').value
        if topics:
            self.graph = GraphRecording(self, bag, topics, PUBLISH_DEPTH, own_only=True,
                                        param='record.topics')
            self._discover()
            if self.bag is None:
                return self.recording_error
            if not self._graph_timers:
                self._graph_timers = [self.create_timer(RECORD_DISCOVERY_S, self._discover),
                                      self.create_timer(DRAIN_PERIOD_S, self._drain_graph)]
        self.get_logger().info(f'recording what this node publishes to {bag.path}'
                               + (f' with {", ".join(topics)}' if topics else ''))
        return ''

    def _discover(self) -> None:
        """Subscribe to the record.topics that have appeared (a topic added to the bag writes
        its metadata: the disk may refuse)."""
        self._graph_step(GraphRecording.discover)

    def _drain_graph(self) -> None:
        """The queued messages of record.topics into the bag."""
        self._graph_step(GraphRecording.drain)

    def _graph_step(self, step) -> None:
        """``step(self.graph)`` while recording record.topics; a write failure stops the
        recording as one of this node's own messages would."""
        if self.graph is None:
            return
        try:
            step(self.graph)
        except BagWriteError as exc:
            self._recording_failed(exc)

    def stop_recording(self) -> str:
        """Finish the bag (summary, metadata.yaml); returns a one-line account."""
        bag, self.bag = self.bag, None
        if bag is None:
            return 'not recording'
        graph, self.graph = self.graph, None
        if graph is not None:
            try:
                if not self.recording_error and self.context.ok():
                    graph.drain()      # what arrived since the last drain
                graph.write_losses()
            except BagWriteError as exc:
                self.recording_error = exc.strerror
            graph.destroy()
        try:
            bag.close()
        except BagWriteError as exc:
            self.recording_error = exc.strerror
        text = f'{bag.message_count} messages on {len(bag.topics)} topics in {bag.path}'
        if self.recording_error:
            text += f' ({self.recording_error})'
        return text

    def _record(self, topic: str, data: bytes, stamp_ns: int) -> None:
        name = self._names[topic]
        if self.graph is not None and self.graph.subscriptions.get(name) is not None:
            return      # a record.topics topic: this node's messages come from the graph too
        try:
            if not self.bag.has_topic(name):
                self.bag.add_topic(name, _type_name(ros_messages.TOPIC_TYPES[topic]),
                                   qos=self._pubs[topic].qos_profile)
            self.bag.write(name, data, stamp_ns)
        except BagWriteError as exc:
            self._recording_failed(exc)

    def _recording_failed(self, exc: BagWriteError) -> None:
        self.recording_error = exc.strerror
        self.get_logger().error(f'recording stopped: {exc.strerror}')
        self.stop_recording()

    def _on_start_recording(self, request, response):
        path = self.get_parameter('record.path').value or default_output()
        error = self.start_recording(path)
        response.success = not error
        response.message = error or f'recording to {self.bag.path}'
        return response

    def _on_stop_recording(self, request, response):
        response.success = self.bag is not None
        response.message = self.stop_recording()
        return response

    def close(self) -> None:
        """Finish a bag being written (entry_point calls this before destroy_node)."""
        if self.bag is not None:
            self.get_logger().info(self.stop_recording())

    def destroy_node(self):
        self.close()
        return super().destroy_node()

    def _set_fault(self, cause: str) -> None:
        self.fault = cause
        self.get_logger().error(f'{cause}; call ~/reset to recover')
        self._restart_pacing()
        self.publish_diagnostics()

    # ---- inputs --------------------------------------------------------------------------
    def _on_speed_cmd(self, msg: Float64) -> None:
        value = msg.data
        limit = self.settings.max_spindle_speed
        if not (math.isfinite(value) and 0.0 <= value <= limit):
            self.counters['commands_refused'] += 1
            self.get_logger().warning(
                f'refused spindle/speed_cmd {value!r}: valid range [0, {limit:g}] rad/s '
                f'(max_spindle_speed); keeping {self.speed_cmd:g} rad/s',
                throttle_duration_sec=WARN_THROTTLE_S)
            return
        self.counters['commands_accepted'] += 1
        self.speed_cmd = value
        if self.settings.spindle_mode == 'speed':
            self.sim.set_speed_command(value)

    def _on_current_cmd(self, msg: Float64) -> None:
        """spindle/current_cmd [A] (torque mode): NaN/inf refused; beyond +-current_limit
        saturated at the limit (as a real drive does) and counted."""
        value = msg.data
        limit = self.settings.motor.I_max
        if not math.isfinite(value):
            self.counters['commands_refused'] += 1
            self.get_logger().warning(
                f'refused spindle/current_cmd {value!r}: a finite current in A is valid; '
                f'keeping {self.current_cmd:g} A', throttle_duration_sec=WARN_THROTTLE_S)
            return
        self.counters['commands_accepted'] += 1
        if abs(value) > limit:
            self.counters['commands_saturated'] += 1
        self.current_cmd = value
        if self.settings.spindle_mode == 'torque':
            self.sim.set_command(value)

    def _set_spindle(self, s) -> None:
        """The spindle of settings s, with the command of its mode."""
        self.sim.set_spindle(s.spindle())
        self.sim.set_command(self.current_cmd if s.spindle_mode == 'torque' else self.speed_cmd)

    def _on_parameters_set(self, parameters) -> None:
        # Validated already; applied at the next step boundary by _apply_parameters.
        self._params_changed = True

    def _apply_parameters(self) -> None:
        if not self._params_changed:
            return
        self._params_changed = False
        old = self.settings
        drive, s = ros_params.settings_from(ros_params.current_values(self))
        self.settings = s
        self._max_lag_ns = _max_stamp_lag_ns(self)
        self.pending_drive = drive
        if drive.n == self.drive.n:
            self.drive = drive
        else:
            self.drive = drive.replace(n=self.drive.n)
            self.get_logger().info(f'n = {drive.n} applies on ~/reset')
        self.sim.set_params(self.drive)
        self._set_spindle(s)
        self.imu.reconfigure(s.imu)
        self.sampler.set_rates(s.publish_every, s.imu_every)
        self.bench.apply(s.bench)
        self._want_scheduling()
        if (s.real_time_factor, s.publish_rate_hz) != (old.real_time_factor,
                                                       old.publish_rate_hz):
            self._restart_pacing()

    # ---- services ------------------------------------------------------------------------
    def _on_reset(self, request, response):
        self._params_changed = True
        self._apply_parameters()
        s = self.settings
        self.drive = self.pending_drive
        self.sim.reset(y0=initial_state(self.drive, s.initial_speed), params=self.drive)
        self.speed_cmd = s.initial_speed
        self.current_cmd = 0.0
        self._set_spindle(s)
        self.imu.seed = s.seed
        self.imu.reset()
        self.bench.reset(s.seed)
        cleared = self.fault
        self.fault = ''
        # Nothing is published now: this step's stamp went out already (with the old state);
        # the next period carries the restored state, so stamps stay strictly increasing.
        self._restart_pacing()
        self.publish_diagnostics()
        response.success = True
        response.message = (f'reset to the initial state at t = {self.stamp_ns() * 1e-9:.6f} s'
                            + (f' (cleared: {cleared})' if cleared else ''))
        return response

    def _on_pause(self, request, response):
        if request.data != self.paused:
            self.paused = request.data
            self._restart_pacing()
            self.publish_diagnostics()
        response.success = True
        response.message = 'paused' if self.paused else 'running'
        return response

    def _on_step(self, request, response):
        if not self.paused:
            response.success, response.message = False, 'not paused: call ~/pause first'
            return response
        if self.fault:
            response.success, response.message = False, f'{self.fault}; call ~/reset'
            return response
        self._apply_parameters()
        response.success = self._integrate_period()
        response.message = (f't = {self.stamp_ns() * 1e-9:.9f} s' if response.success
                            else self.fault)
        return response

    # ---- diagnostics ---------------------------------------------------------------------
    def publish_diagnostics(self) -> None:
        """The simulation status: real_time_factor achieved over the window (and since
        start, paused time excluded), the stamp lag (window and since start) and slips; the
        FG's state (WARN while it reads 0 with the spindle turning below its minimum speed)."""
        wall_ns = self._steady.now().nanoseconds
        wall0, steps0, running = self._diag_window
        self._diag_window = (wall_ns, self.sim.steps, not (self.paused or self.fault))
        wall = (wall_ns - wall0) * 1e-9
        achieved = (self.sim.steps - steps0) * self._dt_ns * 1e-9 / wall if wall > 0 else 0.0
        if running:
            self._run_wall_ns += wall_ns - wall0
            self._run_steps += self.sim.steps - steps0
        since_start = (self._run_steps * self._dt_ns / self._run_wall_ns
                       if self._run_wall_ns > 0 else 0.0)
        lag, slips = self.lag_ns * 1e-9, self._window_slips
        self.lag_ns, self._window_slips = 0, 0
        period = self.sampler.publish_every * self._dt_ns * 1e-9
        target = self.settings.real_time_factor
        if self.fault:
            level, message = DiagnosticStatus.ERROR, self.fault
        elif self.paused:
            level, message = DiagnosticStatus.OK, 'paused'
        else:
            behind = target > 0 and achieved < 0.9 * target
            level = DiagnosticStatus.WARN if behind or lag > period else DiagnosticStatus.OK
            message = (f'running at real_time_factor {achieved:.3f}'
                       + (f' (target {target:g})' if behind else ''))
            if slips:
                level = DiagnosticStatus.ERROR
                message += (f'; cannot keep up: {slips} slip(s), stamps more than '
                            f'max_stamp_lag late were dropped '
                            f'({self.slipped_ns * 1e-9:.3f} s in all)')
            elif lag > period:
                message += f'; stamps up to {lag * 1e3:.1f} ms late (publish period ' \
                           f'{period * 1e3:g} ms)'
                if lag * 1e9 > self._max_lag_ns:
                    level = DiagnosticStatus.ERROR   # one late period, nothing to drop
        if self.recording_error:
            level = max(level, DiagnosticStatus.WARN)
            message += f'; recording stopped: {self.recording_error}'
        fg = self.bench.speed
        fg_state, fg_min_speed = fg.state(self.sim.omega), fg.min_speed
        if fg_state == 'below_min_speed' and fg.value == 0.0:
            level = max(level, DiagnosticStatus.WARN)
            message += (f'; spindle/speed reads 0: the spindle turns below the FG minimum '
                        f'{fg_min_speed:.3f} rad/s')
        contact_note = self.sim.contact_step_note
        if contact_note:
            level = max(level, DiagnosticStatus.WARN)
            message += f'; {contact_note}'
        values = dict(real_time_factor=achieved, real_time_factor_since_start=since_start,
                      target_real_time_factor=target, stamp_lag=lag,
                      stamp_lag_max=self.lag_max_ns * 1e-9,
                      max_stamp_lag=self.get_parameter('max_stamp_lag').value,
                      scheduling=self.scheduling.state,
                      **self.counters, slipped_time=self.slipped_ns * 1e-9,
                      steps=self.sim.steps, sim_time=self.sim.t,
                      rbar=self.sim.rbar, omega=self.sim.omega,
                      wbar=self.drive.wbar(self.sim.omega), speed_cmd=self.speed_cmd,
                      spindle_mode=self.settings.spindle_mode,
                      fg_state=fg_state, fg_min_speed=fg_min_speed,
                      n=self.drive.n, paused=self.paused, fault=self.fault,
                      contact_refined_steps=self.sim.refined_steps,
                      rolling_switches=self.sim.rolling_switches,
                      recording=str(self.bag.path) if self.bag is not None else '',
                      recorded=self.bag.message_count if self.bag is not None else 0,
                      recording_lost=sum(self.graph.lost.values()) if self.graph else 0,
                      **{f'published {t}': count for t, count in self.published.items()})
        if self.settings.spindle_mode == 'torque':
            values.update(current_cmd=self.current_cmd, motor_current=self.sim.motor_current,
                          motor_torque=self.sim.motor_torque)
        stamp_ns = self.stamp_ns()
        self._send('/diagnostics', cdr.diagnostics(
            stamp_ns, f'{self.get_fully_qualified_name()}: simulation', level, message, values),
            stamp_ns)
        self.bench.publish_diagnostics()


def _max_stamp_lag_ns(node) -> float:
    """The ``max_stamp_lag`` parameter [ns]."""
    return node.get_parameter('max_stamp_lag').value * 1e9


def _type_name(cls) -> str:
    """ROS type name of a generated message class: sensor_msgs/msg/JointState."""
    return f'{cls.__module__.split(".")[0]}/msg/{cls.__name__}'


def _warm_up(sim: Simulation) -> None:
    """Compile the kernels (numba, first call in the process) on a copy of the simulation,
    so that the first paced tick is not seconds late."""
    twin = Simulation(sim.params, sim.omega, sim.dt, spindle=sim.spindle, y0=sim.y)
    twin.advance(1)
    twin.accelerations()


def main(args=None):
    return run_node('abb_simulator', SimulatorNode, args)


if __name__ == '__main__':
    sys.exit(main())

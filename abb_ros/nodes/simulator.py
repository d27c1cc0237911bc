"""``ros2 run abb_ros simulator``: the drive as a fixed-rate plant over ROS 2 (node abb_simulator).

A thin rclpy adapter: :class:`abb_ros.model.integrate.Simulation` integrates, a
:class:`abb_ros.model.sampling.PlantSampler` decides when the state and the IMU are due,
:mod:`abb_ros.io.ros_messages` builds the messages (the same functions as the headless
``abb-sim run``). Topics, parameters and services: docs/ros_api.md.

Time: stamps are ``epoch + steps * dt`` in integer nanoseconds. With real_time_factor 1 at
start-up the epoch is the wall clock at start (rounded to a step), so stamps follow wall
time; otherwise the epoch is 0, the node publishes ``/clock`` and stamps are simulated
time (use_sim_time consumers follow). A steady-clock timer paces integration: each tick
integrates every publish period that is due by then (catching up when late, counted as
overruns); with real_time_factor 0 each tick integrates as many periods as fit in
``BATCH_WALL_S`` and the executor serves topics and services in between.
"""

from __future__ import annotations

import math
import os
import sys
import time

from diagnostic_msgs.msg import DiagnosticStatus
from rclpy._rclpy_pybind11 import RCLError
from rclpy.clock import Clock, ClockType
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from abb_ros.io import ros_messages
from abb_ros.model.integrate import Simulation, SpindleMotor, StateError, initial_state
from abb_ros.model.sampling import PlantSampler
from abb_ros.model.sensors import ImuModel
from abb_ros.nodes import ros_params
from abb_ros.nodes.bench import BenchIO
from abb_ros.nodes.entry_point import run_node

NODE_NAME = 'abb_simulator'
QOS_DEPTH = 10
DIAGNOSTICS_PERIOD_S = 1.0
BATCH_WALL_S = 0.005
"""As fast as possible: wall time spent integrating per timer tick before yielding."""
MAX_CATCH_UP = 100
"""Publish periods integrated in one late tick at most; beyond that the pacing re-anchors
(the lost wall time is dropped, counted in ``slips``)."""
WARN_THROTTLE_S = 1.0


class SimulatorNode(Node):
    """The ABB drive simulator node (see the module docstring)."""

    def __init__(self, **kwargs):
        super().__init__(NODE_NAME, **kwargs)
        self.drive, self.settings = ros_params.declare_all(self)
        s = self.settings
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._dt_ns = s.dt_ns
        self.sim = Simulation(self.drive, s.initial_speed, self._dt_ns * 1e-9,
                              spindle=SpindleMotor(s.spindle_max_accel, s.spindle_tau))
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
        self.counters = dict(overruns=0, slips=0, commands_accepted=0, commands_refused=0)
        self.speed_cmd = s.initial_speed
        self._params_changed = False

        self._pubs = {topic: self.create_publisher(kind, topic, QOS_DEPTH)
                      for topic, kind in ros_messages.TOPIC_TYPES.items()}
        self._reuse = {topic: kind() for topic, kind in ros_messages.TOPIC_TYPES.items()}
        self.bench = BenchIO(self, QOS_DEPTH)   # FG, faults, disturbances, markers
        self.create_subscription(Float64, 'spindle/speed_cmd', self._on_speed_cmd, QOS_DEPTH)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self.create_service(Trigger, '~/step', self._on_step)
        self.add_on_set_parameters_callback(lambda ps: ros_params.validate_change(self, ps))
        self.add_post_set_parameters_callback(self._on_parameters_set)

        self._diag_window = (self._steady.now().nanoseconds, self.sim.steps)
        self._diag_timer = self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics,
                                             clock=self._steady)
        self._timer = None
        self._publish(self.sampler.sample_now())
        self._restart_pacing()
        self.get_logger().info(
            f'n = {self.drive.n} balls, omega0 = {self.drive.omega0:.1f} rad/s, initial '
            f'{s.initial_speed:.1f} rad/s, {s.integration_rate_hz} Hz steps, publishing at '
            f'{s.publish_rate_hz} Hz, real_time_factor {s.real_time_factor:g}'
            + (', paused' if self.paused else ''))

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
        if self.paused or self.fault:
            return
        rtf = self.settings.real_time_factor
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
        wall0, steps0 = self._anchor
        every = self.sampler.publish_every
        elapsed = self._steady.now().nanoseconds - wall0
        due = steps0 + int(elapsed * self.settings.real_time_factor) // self._dt_ns
        periods = due // every - self.sim.steps // every
        if periods > 1:
            self.counters['overruns'] += periods - 1
        if periods > MAX_CATCH_UP:
            self.counters['slips'] += 1
            periods = MAX_CATCH_UP
            self._anchor_pacing((self.sim.steps // every + periods) * every)
        for _ in range(max(periods, 0)):
            if not self._integrate_period():
                return

    def _tick_fast(self) -> None:
        self._apply_parameters()
        if self._timer is None:
            return
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
        for topic, msg in ros_messages.sample_messages(
                sample, self._dt_ns, self.imu.config, self._epoch_ns, self.owns_time,
                self._reuse):
            try:
                self._pubs[topic].publish(msg)
            except RCLError:
                if self.context.ok():
                    raise
                return  # shutting down (SIGINT): the context went away under the callback
        self.bench.on_sample(sample)

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
        self.sim.set_speed_command(value)

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
        self.pending_drive = drive
        if drive.n == self.drive.n:
            self.drive = drive
        else:
            self.drive = drive.replace(n=self.drive.n)
            self.get_logger().info(f'n = {drive.n} applies on ~/reset')
        self.sim.set_params(self.drive)
        self.sim.set_spindle(SpindleMotor(s.spindle_max_accel, s.spindle_tau))
        self.imu.reconfigure(s.imu)
        self.sampler.set_rates(s.publish_every, s.imu_every)
        self.bench.apply(s.bench)
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
        self.sim.set_speed_command(s.initial_speed)
        self.speed_cmd = s.initial_speed
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
        wall_ns = self._steady.now().nanoseconds
        wall0, steps0 = self._diag_window
        self._diag_window = (wall_ns, self.sim.steps)
        wall = (wall_ns - wall0) * 1e-9
        achieved = (self.sim.steps - steps0) * self._dt_ns * 1e-9 / wall if wall > 0 else 0.0
        if self.fault:
            level, message = DiagnosticStatus.ERROR, self.fault
        elif self.paused:
            level, message = DiagnosticStatus.OK, 'paused'
        else:
            target = self.settings.real_time_factor
            behind = target > 0 and achieved < 0.9 * target
            level = DiagnosticStatus.WARN if behind else DiagnosticStatus.OK
            message = (f'running at real_time_factor {achieved:.3f}'
                       + (f' (target {target:g})' if behind else ''))
        values = dict(real_time_factor=achieved,
                      target_real_time_factor=self.settings.real_time_factor,
                      **self.counters, steps=self.sim.steps, sim_time=self.sim.t,
                      rbar=self.sim.rbar, omega=self.sim.omega,
                      wbar=self.drive.wbar(self.sim.omega), speed_cmd=self.speed_cmd,
                      n=self.drive.n, paused=self.paused, fault=self.fault)
        self._pubs['/diagnostics'].publish(ros_messages.diagnostics(
            self.stamp_ns(), f'{self.get_fully_qualified_name()}: simulation', level,
            message, values))
        self.bench.publish_diagnostics()


def spin(node: Node) -> None:
    """rclpy.spin with :func:`make_executor`. The loop of timed spin_once calls is what lets
    SIGINT through: the EventsExecutor's own blocking spin does not return on it (Jazzy)."""
    executor = make_executor(node.context)
    executor.add_node(node)
    try:
        while node.context.ok():
            executor.spin_once(timeout_sec=0.1)
    finally:
        executor.remove_node(node)


def make_executor(context):
    """rclpy's EventsExecutor (a C++ event loop: about a third of the per-callback overhead
    of SingleThreadedExecutor, which at 1 kHz decides whether the node keeps real time);
    ABB_ROS_EXECUTOR=single selects the classic one."""
    if os.environ.get('ABB_ROS_EXECUTOR', 'events') == 'single':
        return SingleThreadedExecutor(context=context)
    from rclpy.experimental import EventsExecutor
    return EventsExecutor(context=context)


def _warm_up(sim: Simulation) -> None:
    """Compile the kernels (numba, first call in the process) on a copy of the simulation,
    so that the first paced tick is not seconds late."""
    twin = Simulation(sim.params, sim.omega, sim.dt, spindle=sim.spindle, y0=sim.y)
    twin.advance(1)
    twin.accelerations()


def main(args=None):
    return run_node('abb_simulator', SimulatorNode, args, spin=spin)


if __name__ == '__main__':
    sys.exit(main())

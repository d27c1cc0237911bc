"""The simulator's plant loop: pacing, integration and the one publish path, on the plant's thread.

:class:`PlantLoop` is the part of :class:`abb_ros.nodes.simulator.node.SimulatorNode` that runs the
plant: :class:`abb_ros.runtime.plant_thread.PlantThread` calls :meth:`PlantLoop._plant_tick`
at the deadlines of :class:`abb_ros.runtime.pacing.Pacer` (or an rclpy timer does, with
``ABB_ROS_PACING=timer``); a tick integrates the publish periods due, encodes each sample to
CDR bytes (:mod:`abb_ros.io.wire.cdr`) and publishes them through :meth:`PlantLoop.send`, the one
path of every message the node publishes. The node's executor callbacks hold the plant's
lock: :meth:`PlantLoop.create_subscription`, :meth:`PlantLoop.create_service` and
:meth:`PlantLoop.create_timer` wrap them (rclpy's parameter services included, which Node
creates through them).

A mixin: the node makes the state it uses (``sim``, ``sampler``, ``pacer``, ``imu``, ``hil``,
``recorder``, ``live``, ``ros2_control``, ``run_state``, ``fault``, ``plant``,
``plant_lock`` ...) in its constructor.
"""

from __future__ import annotations

import time
import warnings

from abb_ros.io.wire import cdr
from abb_ros.io.wire.topics import CLOCK_TOPIC, JOINT_STATES, JOINT_STATES_THROTTLE
from abb_ros.model.dynamics.integrate import Simulation, StateError
from abb_ros.model.sensors.imu import ImuModel
from abb_ros.model.sensors.sampling import PlantSampler
from abb_ros.runtime.plant_thread import AGAIN, IDLE, locked

__all__ = ['BATCH_WALL_S', 'PlantLoop', 'RESPONSE_TRIES', 'resend_on_timeout']

BATCH_WALL_S = 0.005
"""As fast as possible: wall time spent integrating per tick before yielding."""
RESPONSE_TRIES = 20
"""How often a service reply is sent while the middleware has not matched the client's reply
reader yet (rmw_fastrtps waits 100 ms each time): 2 s in all, then it is given up, logged."""
RESPONSE_TIMEOUT = 'failed to send response (timeout)'
"""The start of rclpy's RuntimeWarning when rmw dropped a reply for want of that match."""


def resend_on_timeout(send, log, name: str, tries: int = RESPONSE_TRIES):
    """Return ``send`` (a Service's ``send_response``) sending again while rmw times out.

    A client that calls a service as soon as it discovers it may not be matched yet as a
    reader of the replies; rmw_fastrtps then waits 100 ms and drops the reply with only a
    RuntimeWarning (shown once per process), and the client never gets an answer. On a busy
    machine (the plant running as fast as possible, a CPU hog) discovery takes longer than
    that: a ``set_parameters`` call at real_time_factor 0 went unanswered.
    """
    def send_response(response, header) -> None:
        for _ in range(tries):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter('always')
                send(response, header)
            if not any(str(w.message).startswith(RESPONSE_TIMEOUT) for w in caught):
                return
        log.warning(f'{name}: reply lost, the client was not matched within '
                    f'{tries * 0.1:g} s (the middleware dropped it {tries} times)')
    return send_response


class PlantLoop:
    """Pacing, integration and publishing of the simulator node (see the module docstring)."""

    # ---- time ---------------------------------------------------------------------------
    def stamp_ns(self, steps: int | None = None) -> int:
        """Stamp of the state after ``steps`` steps (default: now) [ns]."""
        return self.pacer.stamp_ns(self.sim.steps if steps is None else steps)

    def _max_stamp_lag_ns(self) -> float:
        """Return the ``max_stamp_lag`` setting [ns]."""
        return self.settings.max_stamp_lag * 1e9

    def _restart_pacing(self) -> None:
        """(Re)start the integration for the current mode, anchored now."""
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None
        self._want_scheduling()
        self._running = not (self.paused or self.fault)
        if not self._running:
            if self.pacer.hold():   # /clock starts now, at the held time
                stamp_ns = self.stamp_ns()
                self.send(CLOCK_TOPIC, cdr.clock(*divmod(stamp_ns, 1_000_000_000)), stamp_ns)
            return
        self.pacer.start(self.sim.steps)
        if self.plant is not None:
            self.plant.wake()
        elif self.pacer.free_running:
            self._timer = self.create_timer(0.0, self._tick_fast, clock=self._steady)
        else:
            self._timer = self.create_timer(self.pacer.tick_period_s, self._tick_paced,
                                            clock=self._steady)

    def _want_scheduling(self) -> None:
        """Want SCHED_FIFO at realtime_priority only while paced.

        A FIFO thread that never sleeps (real_time_factor 0) would hold a core.
        """
        self.scheduling.want(0 if self.pacer.free_running else self.settings.realtime_priority)

    # ---- integration ---------------------------------------------------------------------
    def _tick_starts(self) -> bool:
        """Apply what changed since the last tick; whether the plant still runs."""
        self._apply_parameters()
        if not self._running:
            return False
        if self.scheduling.pending:   # in this (the integrating) thread
            self.scheduling.apply_logged(self.get_logger())
        return True

    def _plant_tick(self):
        """Tick the plant (on its thread, under the lock).

        Return the deadline of the next tick, AGAIN or IDLE (:mod:`abb_ros.runtime.plant_thread`).
        """
        if self.pacer.free_running:
            self._tick_fast()
        else:
            self._tick_paced()
        if not self._running:   # the factor, the pause or a fault may have changed in the tick
            return IDLE
        if self.pacer.free_running:
            return AGAIN
        return self.pacer.deadline_ns(self.sim.steps)

    def _on_plant_error(self, exc: Exception) -> None:
        """Stop the plant after a tick raised (a bug), log why, and end the node with exit 1."""
        self._running = False
        self.get_logger().fatal(f'the plant thread failed: {exc!r}; stopping')
        self.exit_code = 1

    def _tick_paced(self) -> None:
        """Integrate the publish periods due on the wall clock."""
        if not self._tick_starts() or self.pacer.free_running:
            return
        for _ in range(self.pacer.due(self.sim.steps)):
            if not self._integrate_period():
                return

    def _tick_fast(self) -> None:
        """Integrate publish periods for ``BATCH_WALL_S`` of wall time."""
        if not self._tick_starts() or not self.pacer.free_running:
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
        """Publish the messages of ``sample`` (None: nothing due)."""
        if sample is None:
            return
        pacer = self.pacer
        stamp_ns, encoded = cdr.sample_cdr(sample, pacer.dt_ns, self.imu.config,
                                           pacer.epoch_ns, pacer.publishes_clock)
        for topic, data in encoded:
            self.send(topic, data, stamp_ns)
            if topic != JOINT_STATES:
                continue
            if self._throttle_slots.opens(stamp_ns, self._throttle_hz):
                self.send(JOINT_STATES_THROTTLE, data, stamp_ns)
            if self.ros2_control is not None:
                self.ros2_control.on_joint_states(data)
        self.hil.on_sample(sample, stamp_ns)

    def send(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Publish the CDR bytes of one message of ``topic`` (a key of the topic list).

        The one path of every message the node publishes: the middleware, the
        ``published <topic>`` counters of /diagnostics, the live view and the bag being
        recorded get the same messages.
        """
        try:
            self._pubs[topic].publish(data)
        except RuntimeError:   # rcl's error: publishing on a context that was shut down
            if self.context.ok():
                raise
            return  # the context was shut down by its owner (tests): nothing to publish to
        self.published[topic] += 1
        if self.live is not None:
            self.live.write(self._bag_topics[topic][0], data, stamp_ns)
        recording = self.recorder.current
        if recording is not None:
            recording.write(*self._bag_topics[topic], data, stamp_ns)

    def _set_fault(self, cause: str) -> None:
        """Stop the plant on ``cause`` until ``~/reset``."""
        self.fault = cause
        self.get_logger().error(f'{cause}; call ~/reset to recover')
        self._restart_pacing()
        self.publish_diagnostics()

    # ---- the executor's callbacks hold the plant's lock --------------------------------
    def create_subscription(self, msg_type, topic, callback, *args, **kwargs):
        """Create the subscription as rclpy does, its callback run under the plant's lock."""
        return super().create_subscription(msg_type, topic, locked(self.plant_lock, callback),
                                           *args, **kwargs)

    def create_service(self, srv_type, srv_name, callback, *args, **kwargs):
        """Create the service as rclpy does, its callback run under the plant's lock.

        Its replies are sent again while the middleware drops them (:func:`resend_on_timeout`).
        """
        service = super().create_service(srv_type, srv_name, locked(self.plant_lock, callback),
                                          *args, **kwargs)
        service.send_response = resend_on_timeout(service.send_response, self.get_logger(),
                                                  service.service_name)
        return service

    def create_timer(self, timer_period_sec, callback, *args, **kwargs):
        """Create the timer as rclpy does, its callback run under the plant's lock."""
        return super().create_timer(timer_period_sec, locked(self.plant_lock, callback),
                                    *args, **kwargs)


def warm_up(sim: Simulation, imu: ImuModel, publish_every: int) -> None:
    """Compile the kernels (numba, first call in the process) on copies of the plant.

    Both ways of sampling a period (in two compiled calls where the IMU is read with every
    state sample, else step by step: ``advance`` then ``sample_now``) and the encoding of a
    sample, so that the first paced tick is not seconds late.
    """
    for fused in (True, False):
        twin = Simulation(sim.params, sim.omega, sim.dt, spindle=sim.spindle, y0=sim.y)
        sampler = PlantSampler(twin, ImuModel(imu.config, seed=imu.seed), publish_every,
                               publish_every)
        if fused:
            samples = sampler.next_period()
        else:
            twin.advance(publish_every)
            samples = [sampler.sample_now()]
        for sample in samples:
            cdr.sample_cdr(sample, 1, imu.config)

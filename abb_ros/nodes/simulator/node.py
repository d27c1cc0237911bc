"""``ros2 run abb_ros simulator``: the drive as a fixed-rate plant over ROS 2 (node abb_simulator).

A thin rclpy adapter: :class:`abb_ros.model.dynamics.integrate.Simulation` integrates, a
:class:`abb_ros.model.sensors.sampling.PlantSampler` decides when the state and the IMU are due,
:mod:`abb_ros.io.wire.cdr` encodes the messages (the headless ``abb-sim run``'s encoder: no rclpy
message is built). Topics, parameters and services: docs/ros_api.md.

Time (:class:`abb_ros.runtime.pacing.Pacer`): stamps are ``epoch + steps * dt`` in integer
nanoseconds, the wall clock while ``/clock`` is silent; from the first time simulated time
departs from the wall clock (a real_time_factor other than 1, a pause, a step, a fault) the
node publishes ``/clock`` with every sample, for good (:mod:`abb_ros.runtime.sim_clock` states
the rule). The plant runs on its own thread (:class:`abb_ros.runtime.plant_thread.PlantThread`),
woken at absolute deadlines one publish period apart: each tick integrates every publish period
that is due by then (catching up when late, counted as overruns; dropped as a slip beyond
``max_stamp_lag``, docs/time_under_load.md); with real_time_factor 0 each tick integrates as
many periods as fit in ``BATCH_WALL_S``. The executor serves services, parameters and
subscriptions; each of its callbacks holds the plant's lock (:meth:`SimulatorNode.create_timer`
and the like wrap them), so that it sees and changes the plant between two ticks. That loop is
:class:`abb_ros.nodes.simulator.plant.PlantLoop`.
``ABB_ROS_PACING=timer`` paces the plant with an rclpy timer in the executor instead (the
earlier way, kept for comparison: benchmarks/bench_plant_thread.py). The /diagnostics status:
:mod:`abb_ros.nodes.simulator.diagnostics`.

``record.path``, ``record.start`` or ``~/start_recording`` / ``~/stop_recording`` write the
published bytes to a bag in process (:class:`abb_ros.nodes.recorder.recording.Recording`; log time
= stamp, as the headless run writes them), with the other nodes' topics ``record.topics``;
``live_view.*`` serve the same bytes to the Foxglove app
(:mod:`abb_ros.nodes.simulator.live_view`); ``ros2_control.*`` connect ros2_control's
topic-based system (:mod:`abb_ros.nodes.simulator.ros2_control`).
"""

from __future__ import annotations

import os
import threading
import time

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from abb_ros.io.wire import cdr, ros_messages
from abb_ros.io.wire.topics import CURRENT_CMD, DIAGNOSTICS, SPEED_CMD
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.parameters.params import ParamError
from abb_ros.model.sensors import entity_kinematics
from abb_ros.model.sensors.imu import ImuModel
from abb_ros.model.sensors.sampling import PlantSampler
from abb_ros.nodes.recorder.recording import default_output, refuse_bad_topics, resolve_topics
from abb_ros.nodes.ros import ros_params
from abb_ros.nodes.ros import stop as stop_request
from abb_ros.nodes.ros.entry_point import make_executor, run_node, spin
from abb_ros.nodes.simulator import live_view, ros2_control, simulation_interfaces
from abb_ros.nodes.simulator.diagnostics import simulation_status
from abb_ros.nodes.simulator.hil_io import HilIO
from abb_ros.nodes.simulator.plant import PlantLoop, warm_up
from abb_ros.nodes.simulator.recording import InProcessRecording
from abb_ros.runtime.pacing import Pacer
from abb_ros.runtime.plant_thread import PlantThread
from abb_ros.runtime.rate_slots import RateSlots
from abb_ros.runtime.realtime import FifoScheduling
from abb_ros.runtime.run_state import (
    PLAYING,
    RESULT_INCORRECT_STATE,
    STATE_NAMES,
    STOPPED,
    RunState,
    Transition,
)
from abb_ros.runtime.spindle_commands import SpindleCommands

NODE_NAME = 'abb_simulator'
QOS_DEPTH = 10
RECORD_DISCOVERY_S = 0.5
"""How often the graph is searched for the record.topics while recording [s]."""
RECORD_DRAIN_S = 0.05
"""How often the record.topics' queued messages are written to the bag [s]: each drain holds
the plant's lock, and PUBLISH_DEPTH messages last 1 s even at 1 kHz."""
PUBLISH_DEPTH = 1000
"""History of each published topic: a reliable subscriber (a recorder) that falls behind by
up to this many messages (1 s at 1 kHz) still gets every one."""
DIAGNOSTICS_PERIOD_S = 1.0
WARN_THROTTLE_S = 1.0
PACING_ENV = 'ABB_ROS_PACING'
PACINGS = ('thread', 'timer')
"""Values of :data:`PACING_ENV`: the plant's own thread (default) or an rclpy timer."""

__all__ = ['SimulatorNode', 'main', 'make_executor', 'spin']


class SimulatorNode(PlantLoop, Node):
    """The ABB drive simulator node (see the module docstring)."""

    def __init__(self, **kwargs):
        self.plant_lock = threading.RLock()   # first: Node.__init__ creates callbacks
        self.plant = None
        super().__init__(NODE_NAME, **kwargs)
        pacing = os.environ.get(PACING_ENV, PACINGS[0])
        if pacing not in PACINGS:
            raise ParamError(PACING_ENV, pacing, ' or '.join(PACINGS), 'environment variable')
        self.drive, self.settings = ros_params.declare_all(self)
        s = self.settings
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.steady_clock = self._steady
        self.sim = Simulation(self.drive, s.initial_speed, s.dt, spindle=s.spindle())
        self.imu = ImuModel(s.imu, seed=s.seed)
        self.sampler = PlantSampler(self.sim, self.imu, s.publish_every, s.imu_every)
        warm_up(self.sim, self.imu, s.publish_every)
        self.pacer = Pacer(s.dt_ns, s.publish_every, s.real_time_factor,
                           self._max_stamp_lag_ns(), time.monotonic_ns,
                           lead=0.0 if pacing == 'thread' else 0.5)
        self._running = False   # integrating (not paused, no fault)
        self.pending_drive = self.drive
        self.fault = ''
        self.run_state = RunState(s.start_paused)
        self.exit_code = None   # set by SetSimulationState QUITTING: run_node's spin ends
        if s.start_paused:
            self.pacer.hold()
        self.commands = SpindleCommands(s.initial_speed)
        self._throttle_slots = RateSlots()
        self._throttle_hz = s.joint_states_throttle_hz
        self.counters = self.commands.counters
        self.scheduling = FifoScheduling()   # of the thread that integrates
        self.published = dict.fromkeys(ros_messages.TOPIC_TYPES, 0)
        self.live = None   # the live view, once started (below)
        self.recorder = InProcessRecording(self, PUBLISH_DEPTH, 'record.topics',
                                           RECORD_DISCOVERY_S, RECORD_DRAIN_S)
        if s.spindle_mode == 'torque':
            self.sim.set_command(0.0)
        self._params_changed = False

        self._pubs = {topic: self.create_publisher(kind, topic, PUBLISH_DEPTH)
                      for topic, kind in ros_messages.TOPIC_TYPES.items()}
        self._bag_topics = {topic: (pub.topic_name, _type_name(ros_messages.TOPIC_TYPES[topic]),
                                    pub.qos_profile) for topic, pub in self._pubs.items()}
        self.hil = HilIO(self)   # FG, faults, disturbances, markers
        self.ros2_control = ros2_control.start(self, ros_messages.TOPIC_TYPES)   # or None
        self.create_subscription(Float64, SPEED_CMD, self._on_speed_cmd, QOS_DEPTH)
        self.create_subscription(Float64, CURRENT_CMD, self._on_current_cmd,
                                 QOS_DEPTH)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self.create_service(Trigger, '~/step', self._on_step)
        self.sim_interfaces = simulation_interfaces.serve(self)
        self.recorder.serve('record.path', prepare=self._prepare_bag)
        self.add_on_set_parameters_callback(
            lambda ps: refuse_bad_topics(self, ps, 'record.topics')
            or ros_params.validate_change(self, ps))
        self.add_post_set_parameters_callback(self._on_parameters_set)

        resolve_topics(self, self.get_parameter('record.topics').value, 'record.topics')
        path = self.get_parameter('record.path').value
        if path or self.get_parameter('record.start').value:
            path = path or default_output()
            error = self.recorder.start(path, self.get_parameter('record.topics').value,
                                        self._prepare_bag)
            if error:
                raise ParamError('record.path', path, 'a directory that does not exist yet, '
                                 'in a writable place', error)
        try:
            self.live = live_view.start(
                self, {'pause': (SetBool, self._on_pause), 'step': (Trigger, self._on_step),
                       'reset': (Trigger, self._on_reset)},
                {name: type_name for name, type_name, _ in self._bag_topics.values()})
        except ParamError:
            self.close()   # the bag started above is finished
            raise
        self.pacer.start_window(self.sim.steps)
        self._diag_timer = self.create_timer(DIAGNOSTICS_PERIOD_S, self.publish_diagnostics,
                                             clock=self._steady)
        self.get_logger().info(
            f'n = {self.drive.n} balls'
            + (f' + race2.n = {self.drive.race2_n} at z = {self.drive.race2_z:g} m'
               if self.drive.race2_n else '')
            + f', omega0 = {self.drive.omega0:.1f} rad/s, initial '
            f'{s.initial_speed:.1f} rad/s, {s.integration_rate_hz} Hz steps, publishing at '
            f'{s.publish_rate_hz} Hz, real_time_factor {s.real_time_factor:g}'
            + (', paused' if self.paused else ''))
        # Last: the pacing is anchored now (the first log line alone can take ~80 ms, which
        # the first tick would otherwise owe, or drop as a slip on a loaded machine).
        self._timer = None
        if pacing == 'thread':
            self.plant = PlantThread(self._plant_tick, self.plant_lock, self._on_plant_error)
        self._publish(self.sampler.sample_now())
        self._restart_pacing()
        if self.plant is not None:
            self.plant.start()

    @property
    def paused(self) -> bool:
        """Whether the plant is frozen (PAUSED or STOPPED)."""
        return self.run_state.paused

    @property
    def speed_cmd(self) -> float:
        """The spindle speed command in force [rad/s]."""
        return self.commands.speed

    @property
    def current_cmd(self) -> float:
        """The motor current command in force [A]."""
        return self.commands.current

    # ---- in-process recording ---------------------------------------------------------------
    def _prepare_bag(self, bag) -> None:
        bag.set_drive_params(self.drive)

    def close(self) -> None:
        """Stop the plant thread, finish a bag being written, stop the live view.

        entry_point calls it before destroy_node.
        """
        if self.plant is not None:
            self.plant.stop()
        if self.recorder.current is not None:
            self.get_logger().info(self.recorder.stop())
        if self.live is not None:
            self.live.close()

    def destroy_node(self):
        """Finish a bag being written, then destroy the node."""
        self.close()
        if getattr(self, 'sim_interfaces', None) is not None:
            self.sim_interfaces.destroy()
        return super().destroy_node()

    # ---- inputs --------------------------------------------------------------------------
    def _on_speed_cmd(self, msg: Float64) -> None:
        refusal = self.commands.take_speed(msg.data, self.settings.max_spindle_speed)
        if refusal:
            self.get_logger().warning(refusal, throttle_duration_sec=WARN_THROTTLE_S)
        elif self.settings.spindle_mode == 'speed':
            self.sim.set_speed_command(msg.data)

    def _on_current_cmd(self, msg: Float64) -> None:
        refusal = self.commands.take_current(msg.data, self.settings.motor.I_max)
        if refusal:
            self.get_logger().warning(refusal, throttle_duration_sec=WARN_THROTTLE_S)
        elif self.settings.spindle_mode == 'torque':
            self.sim.set_command(msg.data)

    def _set_spindle(self, s) -> None:
        """Give the simulation the spindle of settings ``s``, with the command of its mode."""
        self.sim.set_spindle(s.spindle())
        self.sim.set_command(self.commands.of_mode(s.spindle_mode))

    def _on_parameters_set(self, _parameters) -> None:
        # Validated already; applied at the next step boundary by _apply_parameters, which
        # comes now: a plant thread asleep until a deadline far away (a tiny real_time_factor)
        # is woken, and the executor's callbacks (where a timer paces the plant) are at one.
        self._params_changed = True
        if self.plant is not None:
            self.plant.wake()
        elif getattr(self, '_timer', None) is not None:
            self._apply_parameters()

    def _apply_parameters(self) -> None:
        """Apply the parameters set since the last step boundary."""
        if not self._params_changed:
            return
        self._params_changed = False
        old = self.settings
        drive, s = ros_params.settings_from(ros_params.current_values(self))
        self.settings = s
        self.pending_drive = drive
        counts = {name: self.drive.value(name) for name in ('n', 'race2.n')
                  if drive.value(name) != self.drive.value(name)}
        self.drive = drive.replace(**counts) if counts else drive
        for name in counts:
            self.get_logger().info(f'{name} = {drive.value(name)} applies on ~/reset')
        self.sim.set_params(self.drive)
        self._set_spindle(s)
        self.imu.reconfigure(s.imu)
        self.sampler.set_rates(s.publish_every, s.imu_every)
        self.pacer.reconfigure(s.real_time_factor, self.sampler.publish_every,
                               self._max_stamp_lag_ns())
        self.hil.apply(s.hil)
        self._throttle_hz = s.joint_states_throttle_hz
        self._want_scheduling()
        if (s.real_time_factor, s.publish_rate_hz) != (old.real_time_factor,
                                                       old.publish_rate_hz):
            self._restart_pacing()

    # ---- run state, stepping, reset (std_srvs services and simulation_interfaces) -------
    def goal_owns_stepping(self) -> str:
        """Why a SimulateSteps goal refuses play, stop, step and reset now ('' when none runs)."""
        server = getattr(self, 'sim_interfaces', None)
        return server.goal_owns_stepping() if server is not None else ''

    def set_run_state(self, target: int) -> Transition:
        """SetSimulationState: move to ``target`` as :class:`RunState` allows.

        PLAYING and STOPPED are refused (RESULT_INCORRECT_STATE) while a SimulateSteps goal
        owns the stepping.
        """
        owner = self.goal_owns_stepping()
        if owner and target in (PLAYING, STOPPED):
            return Transition(RESULT_INCORRECT_STATE, f'{STATE_NAMES[target]} refused: {owner}')
        transition = self.run_state.request(target)
        if transition.ok:
            if transition.reset:
                self.reset_simulation(time=True, state=True)
            self._restart_pacing()
            self.publish_diagnostics()
            if transition.quit:
                self.get_logger().info('STATE_QUITTING requested: shutting down')
                self.exit_code = 0
        return transition

    def step_periods(self, count: int) -> int:
        """Integrate and publish ``count`` publish periods; return how many.

        A fault stops it, and so does a stop signal (SIGINT, SIGTERM): the node then answers
        and ends at once.
        """
        self._apply_parameters()
        self.run_state.stepped()
        done = 0
        while (done < count and not self.fault and not stop_request.REQUEST
               and self._integrate_period()):
            done += 1
        return done

    def reset_simulation(self, time: bool, state: bool) -> None:
        """Reset the state and/or the time (ResetSimulation's SCOPE_STATE and SCOPE_TIME).

        The state: the initial state, commands, IMU and HIL re-seeded, fault cleared, pending
        parameters applied. The time: the step count back to 0. A reset of the time with
        simulated-time stamps publishes the start sample at once (as at start-up): the stamps
        and /clock go back to 0. Wall-clock stamps cannot go back: they carry on (the
        simulated time inside, which a spindle profile follows, restarts). A reset of the
        state alone publishes nothing: this step's stamp went out already (with the old
        state), the next period carries the restored state, so stamps stay strictly
        increasing.
        """
        self._params_changed = True
        self._apply_parameters()
        s = self.settings
        if state:
            self.drive = self.pending_drive
            self.sim.reset(y0=initial_state(self.drive, s.initial_speed), params=self.drive)
            self.commands.reset(s.initial_speed)
            self._set_spindle(s)
            self.imu.seed = s.seed
            self.imu.reset()
            self.fault = ''
        if state or time:
            self.hil.reset(s.seed)   # the FG's edges are timed on the simulated clock
        if time:
            went_back = self.pacer.rewind(self.sim.steps)
            self.sim.steps = 0
            if went_back:
                self._publish(self.sampler.sample_now())
        self._restart_pacing()
        self.publish_diagnostics()

    def entity_kinematics(self) -> dict[str, entity_kinematics.Kinematics]:
        """Ground truth of the deck, the rotor and the balls now (base frame)."""
        return entity_kinematics.kinematics(self.sim.y, self.sim.accelerations(),
                                            self.sim.params)

    def set_entity(self, name: str, state) -> None:
        """SetEntityState of the deck or a ball (raises EntityError with the reason).

        Refused as well when the next publish period from the new state would stop the plant
        (:func:`abb_ros.model.sensors.entity_kinematics.with_entity`).
        """
        self.sim.y[:] = entity_kinematics.with_entity(
            self.sim, name, *simulation_interfaces.state_vectors(state),
            trial_steps=self.sampler.publish_every)

    def _on_reset(self, _request, response):
        owner = self.goal_owns_stepping()
        if owner:
            response.success, response.message = False, f'reset refused: {owner}'
            return response
        cleared = self.fault
        self.reset_simulation(time=False, state=True)
        response.success = True
        response.message = (f'reset to the initial state at t = {self.stamp_ns() * 1e-9:.6f} s'
                            + (f' (cleared: {cleared})' if cleared else ''))
        return response

    def _on_pause(self, request, response):
        owner = self.goal_owns_stepping()
        if owner and not request.data:
            response.success, response.message = False, f'resume refused: {owner}'
            return response
        if request.data != self.paused:
            self.run_state.pause(request.data)
            self._restart_pacing()
            self.publish_diagnostics()
        response.success = True
        response.message = 'paused' if self.paused else 'running'
        return response

    def _on_step(self, _request, response):
        owner = self.goal_owns_stepping()
        if owner:
            response.success, response.message = False, f'step refused: {owner}'
            return response
        if not self.paused:
            response.success, response.message = False, 'not paused: call ~/pause first'
            return response
        if self.fault:
            response.success, response.message = False, f'{self.fault}; call ~/reset'
            return response
        response.success = self.step_periods(1) == 1
        response.message = (f't = {self.stamp_ns() * 1e-9:.9f} s' if response.success
                            else self.fault)
        return response

    # ---- diagnostics ---------------------------------------------------------------------
    def publish_diagnostics(self) -> None:
        """Publish the simulation status (and the HIL I/O's) on /diagnostics."""
        window = self.pacer.close_window(self.sim.steps, not (self.paused or self.fault))
        level, message, values = simulation_status(self, window)
        stamp_ns = self.stamp_ns()
        self.send(DIAGNOSTICS, cdr.diagnostics(
            stamp_ns, f'{self.get_fully_qualified_name()}: simulation', level, message, values),
            stamp_ns)
        self.hil.publish_diagnostics()


def _type_name(cls) -> str:
    """Return the ROS type name of a generated message class: sensor_msgs/msg/JointState."""
    return f'{cls.__module__.split(".")[0]}/msg/{cls.__name__}'


def main(args=None):
    """Run the simulator node until SIGINT/SIGTERM; return the exit code."""
    return run_node(NODE_NAME, SimulatorNode, args, kind='simulator')

"""``ros2 run abb_ros spin_controller``: bring the drive from rest to a target speed and hold it.

An example controller (node abb_spin_controller) for the plant. On each ``joint_states``
(velocity[0] = omega, header stamp = time) it advances the speed reference of
:class:`abb_ros.nodes.spin_controller.run_up.RunUp` and publishes exactly one command: in ``mode``
speed a ``spindle/speed_cmd`` (std_msgs/Float64, rad/s), the reference plus a PI correction of the
measured speed error (gains ``kp``, ``ki``; the integral runs only while holding); in ``mode``
torque (the simulator's ``spindle.mode`` torque) a ``spindle/current_cmd`` (std_msgs/Float64, A)
from the speed loop :class:`abb_ros.nodes.spin_controller.speed_loop.SpeedLoop` (feedforward of the
reference's acceleration and of the friction, PI at ``loop_bandwidth``, anti-windup at the current
limit) with the node's ``motor.*``, which must be the simulator's. The reference ramps at
``acceleration`` where the balanced equilibrium is stable and jumps over the unbalanced bands (from
:func:`abb_ros.model.stability.speed_bands.speed_table` of the node's own ``drive.*``, computed at
start-up: give it the simulator's parameter file) so that the drive crosses them at its own
acceleration limit; it holds ``target_speed`` only if the analysis calls it balanced, else the
nearest speed that is (with a guard of ``guard_wbar``, logged). ``stability/margin`` from the
analysis node is watched: a negative margin while holding is reported (it does not change the
command, so lockstep runs stay deterministic). Parameters: docs/ros_api.md.
"""

from __future__ import annotations

import math

from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from abb_ros.io.wire.topics import CURRENT_CMD, JOINT_STATES, SPEED_CMD, STABILITY_MARGIN
from abb_ros.model.dynamics.spindle import TorqueMotor
from abb_ros.model.parameters.params import PARAM_SPECS, DriveParams, ParamError
from abb_ros.model.stability import speed_bands
from abb_ros.nodes.ros import ros_params
from abb_ros.nodes.ros.entry_point import run_node
from abb_ros.nodes.ros.parameter_table import specs_for
from abb_ros.nodes.spin_controller.run_up import RunUp, hold_speed
from abb_ros.nodes.spin_controller.speed_loop import SpeedLoop, rotor_inertia

NODE_NAME = 'abb_spin_controller'
QOS_DEPTH = 10
WARN_THROTTLE_S = 5.0
COMMAND_TOPICS = {'speed': SPEED_CMD, 'torque': CURRENT_CMD}
"""The command topic of each mode."""
MOTOR_PREFIX = 'motor.'

PARAMS = specs_for('spin_controller')
"""{ROS name: spec}: drive.*, motor.*, max_spindle_speed and the controller's own
(abb_ros/nodes/spin_controller/params.py and the model's specs)."""


class SpinController(Node):
    """The example run-up controller (see the module docstring)."""

    def __init__(self, **kwargs):
        super().__init__(NODE_NAME, **kwargs)
        self.drive, self.omega_max = self._declare()
        mode = self.get_parameter('mode').value
        self.loop = None            # SpeedLoop in torque mode
        if mode == 'torque':
            self.loop = SpeedLoop(self._motor(), rotor_inertia(self.drive),
                                  self.get_parameter('loop_bandwidth').value)
        self.guard = self.get_parameter('guard_wbar').value * self.drive.omega0
        table = speed_bands.speed_table(self.drive, self.omega_max,
                                        self.get_parameter('table_points').value)
        if not table.exists:
            raise ParamError('drive', 'these parameters', 'a drive the balls can balance',
                             table.reason)
        self.bands = table.bands
        self.margin = math.nan
        self.run_up = None          # RunUp, from the first joint_states on
        self.last_stamp_ns = None
        self.integral = 0.0
        self.command = math.nan
        self._plan()
        self.add_on_set_parameters_callback(self._validate)
        self.add_post_set_parameters_callback(lambda _: self._plan())
        self._pub = self.create_publisher(Float64, COMMAND_TOPICS[mode], QOS_DEPTH)
        self.create_subscription(JointState, JOINT_STATES, self._on_joint_states, QOS_DEPTH)
        self.create_subscription(Float64, STABILITY_MARGIN, self._on_margin, QOS_DEPTH)
        self.get_logger().info(
            f'mode {mode}; unbalanced bands [rad/s]: '
            + ', '.join(f'{b.lo:.0f}-{b.hi:.0f}' for b in self.bands)
            + f'; holding {self.hold:.1f} rad/s')

    # ---- parameters ----------------------------------------------------------------------
    def _declare(self) -> tuple[DriveParams, float]:
        shared = {k: s for k, s in PARAMS.items() if k == 'max_spindle_speed'
                  or k.startswith((ros_params.DRIVE_PREFIX, MOTOR_PREFIX))}
        ros_params.declare(self, shared)
        drive = DriveParams.from_mapping({name: self.get_parameter(
            ros_params.DRIVE_PREFIX + name).value for name in PARAM_SPECS})
        own = {k: s for k, s in PARAMS.items() if k not in shared}
        ros_params.declare(self, own, {'target_speed': ros_params.P3_WBAR * drive.omega0})
        ros_params.coerce_on_set(self, PARAMS)
        return drive, float(self.get_parameter('max_spindle_speed').value)

    def _motor(self) -> TorqueMotor:
        return TorqueMotor.from_values({k: self.get_parameter(k).value for k in PARAMS
                                        if k.startswith(MOTOR_PREFIX)})

    def _validate(self, parameters) -> SetParametersResult:
        for p in parameters:
            if p.name == 'target_speed':
                try:
                    hold_speed(self.bands, p.value, self.omega_max, self.guard)
                except ValueError as err:
                    return SetParametersResult(successful=False, reason=f'target_speed: {err}')
        return SetParametersResult(successful=True)

    def _plan(self) -> None:
        """(Re)compute the hold speed and the reference's acceleration from the parameters."""
        target = self.get_parameter('target_speed').value
        try:
            self.hold = hold_speed(self.bands, target, self.omega_max, self.guard)
        except ValueError as err:
            raise ParamError('target_speed', target, f'(0, {self.omega_max:g}] rad/s', str(err))
        if self.hold != target:
            self.get_logger().warning(
                f'target_speed {target:.1f} rad/s is not balanced (too close to or inside an '
                f'unbalanced band); holding {self.hold:.1f} rad/s instead')
        self.kp = self.get_parameter('kp').value
        self.ki = self.get_parameter('ki').value
        if self.loop is not None:
            self.loop.motor = self._motor()
            self.loop.bandwidth = self.get_parameter('loop_bandwidth').value
        if self.run_up is not None:
            self.run_up.hold = self.hold
            self.run_up.accel = self.get_parameter('acceleration').value

    # ---- control -------------------------------------------------------------------------
    def _on_joint_states(self, msg: JointState) -> None:
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        omega = float(msg.velocity[0]) if msg.velocity else math.nan
        if not math.isfinite(omega):
            self.get_logger().warning(f'joint_states without a finite spindle speed: {omega!r}',
                                      throttle_duration_sec=WARN_THROTTLE_S)
        elif self.run_up is None or stamp_ns <= self.last_stamp_ns:
            # First message, or time went back (a reset): start the reference where we are.
            self.run_up = RunUp(self.bands, self.hold, self.get_parameter('acceleration').value,
                                self.guard, omega_ref=omega)
            self.integral = 0.0
            if self.loop is not None:
                self.loop.integral = 0.0
            self.last_stamp_ns = stamp_ns
            self.command = self._law(omega, 0.0)
        else:
            dt = (stamp_ns - self.last_stamp_ns) * 1e-9
            self.last_stamp_ns = stamp_ns
            self.command = self._law(omega, dt)
        if math.isfinite(self.command):
            self._pub.publish(Float64(data=self.command))

    def _law(self, omega: float, dt: float) -> float:
        """Return the command of the control law.

        Speed mode: reference + kp e + ki int(e) (integral while holding), within
        [0, max speed]; torque mode: the speed loop's current.
        """
        if self.loop is not None:
            # The reference one period ahead (the period is steady): the current held over
            # the next period accelerates along the reference to its next value.
            ref = self.run_up.omega_ref
            alpha = (self.run_up.step(dt) - ref) / dt if dt > 0.0 else 0.0
            return self.loop.step(ref, alpha, omega, dt)
        ref = self.run_up.step(dt)
        error = ref - omega
        if self.run_up.holding:
            self.integral += error * dt
        else:
            self.integral = 0.0
        return min(max(ref + self.kp * error + self.ki * self.integral, 0.0), self.omega_max)

    def _on_margin(self, msg: Float64) -> None:
        self.margin = msg.data
        if self.run_up is not None and self.run_up.holding and not self.margin > 0.0:
            self.get_logger().warning(
                f'the analysis reports margin {self.margin:.4g} (unbalanced) at the hold speed '
                f'{self.hold:.1f} rad/s: are its drive parameters this node\'s?',
                throttle_duration_sec=WARN_THROTTLE_S)


def main(args=None):
    """Run the spin controller until SIGINT/SIGTERM; return the exit code."""
    # The simulator's spin: the EventsExecutor keeps up with 1 kHz joint_states, and its timed
    # loop lets SIGINT through.
    return run_node(NODE_NAME, SpinController, args, kind='spin_controller')


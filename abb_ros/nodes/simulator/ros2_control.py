"""The simulator node's ros2_control bridge: the two topics of the topic-based system.

ros2_control's topic-based system (the plugin
``joint_state_topic_hardware_interface/JointStateTopicSystem`` of
topic_based_hardware_interfaces, the bridge used for Isaac Sim) closes a controller manager's
loop over two sensor_msgs/JointState topics. With ``ros2_control.enabled`` the node is the
other end of both (:class:`Ros2ControlBridge`):

* commands, on ``ros2_control.joint_commands_topic`` (reliable, as the system publishes them:
  depth 1, only the declared command interfaces filled, sent when a command changes): the
  ``spindle`` entry's ``velocity`` is a speed command [rad/s], its ``effort`` a torque command
  [N m] (torque mode), read by :func:`abb_ros.runtime.spindle_commands.joint_command` and
  taken by :meth:`abb_ros.runtime.spindle_commands.SpindleCommands.take_joint_command` with the
  checks of ``spindle/speed_cmd`` and ``spindle/current_cmd``. A refused message (another
  joint, an empty name array, mismatched lengths, a position, a non-finite or out-of-range
  value) changes nothing; it is logged, one warning per kind of fault per
  :data:`WARN_THROTTLE_S`, and counted (``commands_refused`` and ``ros2_control
  refused`` on /diagnostics);
* states, on ``ros2_control.joint_states_topic`` with sensor-data QoS (the system's
  subscription): every ``joint_states`` message the node publishes, the same bytes
  (``spindle``, ``ball_1``.. with position and velocity, the spindle's effort in torque mode,
  stamped by the plant's time, on the ``/clock`` timeline once the node publishes it), which
  the system reads at its next control cycle.

The copy goes to the middleware only: the bag and the live view have ``joint_states``.
Semantics: docs/ros_api.md, 'ros2_control (topic-based system)'.
"""

from __future__ import annotations

import math
import time

from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import JointState

from abb_ros.io.wire.topics import CURRENT_CMD, SPEED_CMD
from abb_ros.model.parameters.params import ParamError
from abb_ros.nodes.recorder.recording import resolve_topics
from abb_ros.runtime.spindle_commands import joint_command

__all__ = ['COMMAND_QOS', 'WARN_THROTTLE_S', 'Ros2ControlBridge', 'start']

WARN_THROTTLE_S = 1.0
"""At most one warning per kind of refusal in this long [s] (wall clock)."""
COMMAND_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
"""The commands' subscription: reliable, as the system's publisher (depth 1) offers them."""

_COMMANDS, _STATES = 'ros2_control.joint_commands_topic', 'ros2_control.joint_states_topic'


class Ros2ControlBridge:
    """The two topics of ros2_control's topic-based system (see the module docstring).

    ``node`` must have ``commands``, ``settings``, ``sim``, ``get_logger()``,
    ``create_subscription`` and ``create_publisher``; ``commands_topic`` and ``states_topic``
    are resolved names (:func:`start` checks them).
    """

    def __init__(self, node, commands_topic: str, states_topic: str):
        self.node = node
        self.commands_topic, self.states_topic = commands_topic, states_topic
        self.counters = {'ros2_control commands': 0, 'ros2_control refused': 0,
                         'ros2_control states published': 0}
        self._warned = {}   # kind of refusal -> time.monotonic() of its last warning
        self._states = node.create_publisher(JointState, states_topic, qos_profile_sensor_data)
        node.create_subscription(JointState, commands_topic, self._on_command, COMMAND_QOS)

    def on_joint_states(self, data: bytes) -> None:
        """Publish the CDR bytes of one joint_states message on the states topic."""
        try:
            self._states.publish(data)
        except RuntimeError:   # rcl's error: publishing on a context that was shut down
            if self.node.context.ok():
                raise
            return
        self.counters['ros2_control states published'] += 1

    def values(self) -> dict[str, object]:
        """Return the bridge's /diagnostics values: its topics and counters."""
        return {'ros2_control joint_commands_topic': self.commands_topic,
                'ros2_control joint_states_topic': self.states_topic, **self.counters}

    def _on_command(self, msg: JointState) -> None:
        node = self.node
        self.counters['ros2_control commands'] += 1
        command, kind, why = joint_command(msg.name, msg.position, msg.velocity, msg.effort)
        if command is None:
            self._refused(kind, node.commands.refuse(
                f'refused {self.commands_topic} command: {why}; the commands in force stay'))
            return
        s = node.settings
        refusal = node.commands.take_joint_command(command, s.max_spindle_speed, s.motor.K_t,
                                                   s.motor.I_max, self.commands_topic)
        if refusal:
            finite = all(math.isfinite(v) for v in (command.velocity, command.effort)
                         if v is not None)
            self._refused('out_of_range' if finite else 'non_finite', refusal)
        elif s.spindle_mode == 'speed' and command.velocity is not None:
            node.sim.set_speed_command(node.commands.speed)
        elif s.spindle_mode == 'torque' and command.effort is not None:
            node.sim.set_command(node.commands.current)

    def _refused(self, kind: str, why: str) -> None:
        self.counters['ros2_control refused'] += 1
        now = time.monotonic()
        if now - self._warned.get(kind, -math.inf) >= WARN_THROTTLE_S:
            self._warned[kind] = now
            self.node.get_logger().warning(why)


def start(node, taken) -> Ros2ControlBridge | None:
    """Start the bridge of ``node`` if ``ros2_control.enabled``; None otherwise.

    ``taken``: the node's own topics (names as published or subscribed). Raises ParamError
    naming the parameter for a topic name that is not valid, that is the other one's, or
    that the node uses already.
    """
    if not node.get_parameter('ros2_control.enabled').value:
        return None
    own = resolve_topics(node, [*taken, SPEED_CMD, CURRENT_CMD], 'ros2_control')
    names = {}
    for param in (_COMMANDS, _STATES):
        value = node.get_parameter(param).value
        (name,) = resolve_topics(node, [value], param)
        if name in own or name in names.values():
            raise ParamError(param, value, 'a ROS topic name that the node does not use '
                             'already, other than the other ros2_control topic',
                             f'{name} is taken')
        names[param] = name
    return Ros2ControlBridge(node, names[_COMMANDS], names[_STATES])

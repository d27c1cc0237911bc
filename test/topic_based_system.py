"""A stand-in for ros2_control's topic-based system, for tests (not part of the package).

controller_manager and ``joint_state_topic_hardware_interface/JointStateTopicSystem`` have no
PyPI wheel, so the tests talk to the simulator as the plugin does, from an rclpy node over real
DDS: commands are sensor_msgs/JointState on the commands topic from a reliable publisher of
depth 1, holding the declared joints' names and only their declared command interfaces (here
``velocity`` and/or ``effort`` of ``spindle``), published only when a command changes; states
are read from the states topic with sensor-data QoS, the latest message each control cycle
(so one cycle late).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import JointState

COMMANDS_TOPIC = '/robot_joint_commands'
STATES_TOPIC = '/robot_joint_states'
COMMAND_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
XACRO = '{http://www.ros.org/wiki/xacro}'
PLUGIN = 'joint_state_topic_hardware_interface/JointStateTopicSystem'


def filled_urdf(urdf_xacro: Path, **args: str) -> ET.Element:
    """Return the ``<robot>`` of ``urdf_xacro`` with its ``$(arg ...)`` filled.

    The args are the file's ``xacro:arg`` defaults, overridden by ``args`` (as
    ``xacro file name:=value`` would); the file may use no other xacro feature.
    """
    root = ET.parse(urdf_xacro).getroot()
    values = {a.get('name'): a.get('default') for a in root.iter(f'{XACRO}arg')}
    values.update(args)
    text = re.sub(r'\$\(arg ([A-Za-z_]\w*)\)', lambda m: values[m.group(1)],
                  ET.tostring(root, encoding='unicode'))
    filled = ET.fromstring(text)
    unknown = [e.tag for e in filled.iter() if str(e.tag).startswith(XACRO)
               and e.tag != f'{XACRO}arg']
    if unknown:
        raise ValueError(f'{urdf_xacro}: xacro features other than arg: {unknown}')
    return filled


def ros2_control_block(urdf_xacro: Path, **args: str) -> ET.Element:
    """Return the one ``<ros2_control>`` element of :func:`filled_urdf`."""
    (block,) = filled_urdf(urdf_xacro, **args).iter('ros2_control')
    return block


class TopicBasedSystem:
    """The plugin's two topics on ``node``, for joints ``joints`` with ``interfaces``.

    ``interfaces``: the command interfaces each joint declares ('velocity', 'effort').
    """

    def __init__(self, node, joints=('spindle',), interfaces=('velocity',),
                 commands_topic=COMMANDS_TOPIC, states_topic=STATES_TOPIC):
        self.node = node
        self.joints, self.interfaces = list(joints), tuple(interfaces)
        self.publisher = node.create_publisher(JointState, commands_topic, COMMAND_QOS)
        self.states = []
        node.create_subscription(JointState, states_topic, self.states.append,
                                 qos_profile_sensor_data)
        self._last = None
        self.sent = 0

    @classmethod
    def from_urdf(cls, node, urdf_xacro: Path) -> 'TopicBasedSystem':
        """The system that ``urdf_xacro``'s ``<ros2_control>`` block declares (its plugin)."""
        block = ros2_control_block(urdf_xacro)
        hardware = block.find('hardware')
        if hardware.findtext('plugin') != PLUGIN:
            raise ValueError(f'{urdf_xacro}: the plugin is not {PLUGIN}')
        params = {p.get('name'): p.text for p in hardware.iter('param')}
        joints = block.findall('joint')
        interfaces = {tuple(c.get('name') for c in j.iter('command_interface')) for j in joints}
        if len(interfaces) != 1:
            raise ValueError(f'{urdf_xacro}: joints with different command interfaces')
        return cls(node, joints=[j.get('name') for j in joints], interfaces=interfaces.pop(),
                   commands_topic=params['joint_commands_topic'],
                   states_topic=params['joint_states_topic'])

    def connected(self) -> bool:
        """Whether the simulator subscribes the commands and a state was read."""
        return self.publisher.get_subscription_count() > 0 and bool(self.states)

    def read(self) -> dict[str, tuple[float, float]]:
        """The latest state read: {joint: (position, velocity)}."""
        msg = self.states[-1]
        return {name: (msg.position[i], msg.velocity[i]) for i, name in enumerate(msg.name)}

    def write(self, **commands: float) -> bool:
        """Send the commands (``velocity=``, ``effort=``, one per joint) if they changed.

        Returns whether a message was sent (the plugin sends none for an unchanged command).
        """
        values = tuple(commands[i] for i in self.interfaces)
        if self._last is not None and all(
                a == b or (math.isnan(a) and math.isnan(b)) for a, b in zip(values, self._last)):
            return False
        self._last = values
        msg = JointState(name=self.joints)
        msg.header.stamp = self.node.get_clock().now().to_msg()
        for interface, value in zip(self.interfaces, values):
            setattr(msg, interface, [float(value)] * len(self.joints))
        self.send(msg)
        return True

    def send(self, msg: JointState) -> None:
        """Publish ``msg`` as it is (a malformed one too)."""
        self.publisher.publish(msg)
        self.sent += 1

"""The simulator as the hardware of ros2_control's topic-based system, over real rclpy and DDS.

controller_manager has no PyPI wheel, so :class:`topic_based_system.TopicBasedSystem` (test/,
not the package) stands in for ``joint_state_topic_hardware_interface/JointStateTopicSystem``:
reliable depth-1 commands holding only the declared interfaces, sent when they change, and
states read with sensor-data QoS, configured (joints, interfaces, topics) by the shipped
config/ros2_control/abb_spindle.urdf.xacro. Each test has its own rclpy Context; nothing is mocked.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import rclpy
from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from test_simulator_node import Plant, stamp_ns
from topic_based_system import COMMANDS_TOPIC, STATES_TOPIC, TopicBasedSystem

from abb_ros.model.parameters.param_spec import ParamError
from abb_ros.model.parameters.plant_spec import MOTOR_DEFAULTS
from abb_ros.nodes.simulator.node import SimulatorNode

pytestmark = pytest.mark.ros

FAST = {'real_time_factor': 0.0, 'publish_rate_hz': 100, 'imu.rate_hz': 100}
ENABLED = {**FAST, 'ros2_control.enabled': True}
JOINTS = ['spindle', 'ball_1', 'ball_2']   # Table 1: two balls
SHIPPED_URDF = Path(__file__).resolve().parents[3] / 'config/ros2_control/abb_spindle.urdf.xacro'
LOG_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


@pytest.fixture
def plants():
    made = []

    def make(**params):
        made.append(Plant(**params))
        return made[-1]

    yield make
    for plant in made:
        plant.close()


def connect(plant, **kwargs) -> TopicBasedSystem:
    """The stand-in, as the shipped URDF declares it (or as ``kwargs`` say), once connected."""
    system = TopicBasedSystem(plant.node, **kwargs) if kwargs else \
        TopicBasedSystem.from_urdf(plant.node, SHIPPED_URDF)
    plant.wait(system.connected, 'the simulator on both topics')
    return system


def test_the_measured_spindle_speed_follows_a_velocity_command_from_ros2_control(plants):
    plant = plants(**ENABLED)
    measured = plant.collect(Float64, 'spindle/speed')
    system = connect(plant)
    assert system.write(velocity=300.0)
    assert not system.write(velocity=300.0)   # unchanged: the plugin sends nothing
    plant.wait(lambda: abs(system.read()['spindle'][1] - 300.0) < 1e-3,
               'the spindle state at 300 rad/s')
    plant.wait(lambda: measured and measured[-1].data == pytest.approx(300.0, rel=0.01),
               'the FG measuring 300 rad/s')
    plant.wait(lambda: plant.values().get('ros2_control commands') == '1', 'one command')
    assert plant.values()['commands_accepted'] == '1'
    system.write(velocity=500.0)
    plant.wait(lambda: abs(system.read()['spindle'][1] - 500.0) < 1e-3, '500 rad/s')


def test_states_carry_every_joint_with_position_and_velocity_on_the_plants_clock(plants):
    plant = plants(**ENABLED)   # real_time_factor 0: the node publishes /clock from start-up
    clock = plant.collect(Clock, '/clock')
    joint_states = plant.collect(JointState, 'joint_states')
    system = connect(plant)
    sim_time = Node('sim_time_reader', context=plant.ctx,
                    parameter_overrides=[Parameter('use_sim_time', value=True)])
    plant.test_executor.add_node(sim_time)
    plant.wait(lambda: len(system.states) > 50, 'fifty states')
    plant.pause(True)
    plant.drain(clock)
    states = list(system.states)
    for msg in states:
        assert list(msg.name) == JOINTS
        assert len(msg.position) == len(msg.velocity) == len(JOINTS)
        assert list(msg.effort) == []   # speed mode: no torque
        assert all(map(math.isfinite, [*msg.position, *msg.velocity]))
    stamps = [stamp_ns(m) for m in states]
    assert stamps == sorted(set(stamps))
    by_stamp = {stamp_ns(m): m for m in joint_states}
    assert set(stamps) <= set(by_stamp)   # the node's joint_states, message for message
    assert all(list(m.position) == list(by_stamp[stamp_ns(m)].position) for m in states)
    assert set(stamps) <= {stamp_ns(c) for c in clock}   # on the /clock timeline
    now = sim_time.get_clock().now().nanoseconds   # a use_sim_time reader's clock
    assert stamps[-1] <= now <= max(stamp_ns(c) for c in clock)
    sim_time.destroy_node()


def test_in_torque_mode_effort_is_the_torque_command_and_the_states_carry_the_motor_torque(
        plants):
    """0.005 N m commanded (0.5 A at K_t 0.01 N m/A): each state's effort is K_t i of its own
    speed, the 0.5 A until the back-EMF leaves less (R i + K_t omega <= V_s: above 1100 rad/s,
    which the free spindle passes on its way to about 1200 rad/s at real_time_factor 0)."""
    K_t, R, V_s = (MOTOR_DEFAULTS[k] for k in ('torque_constant', 'resistance', 'voltage_limit'))
    plant = plants(**ENABLED, **{'spindle.mode': 'torque'})
    system = connect(plant, interfaces=('effort',))
    system.write(effort=0.005)
    plant.wait(lambda: float(plant.values().get('current_cmd', 'nan')) == pytest.approx(0.5),
               'current_cmd 0.5 A')
    plant.wait(lambda: system.states[-1].velocity[0] > 1150.0, 'the spindle past 1150 rad/s')
    driven = [m for m in system.states if m.effort[0] != 0.0]
    assert driven and all(len(m.effort) == len(JOINTS) and list(m.effort[1:]) == [0.0, 0.0]
                          for m in driven)
    for msg in driven:   # to rounding: the node computes the same two lines
        current = min(0.5, (V_s - K_t * msg.velocity[0]) / R)
        assert msg.effort[0] == pytest.approx(K_t * current, rel=1e-9, abs=1e-15)
    assert driven[0].effort[0] == pytest.approx(0.005)   # below 1100 rad/s: the whole command
    assert driven[-1].effort[0] < 0.001                   # the back-EMF's limit


MALFORMED = (
    ('another joint', JointState(name=['ball_1'], velocity=[100.0]), "['ball_1']"),
    ('an empty name array', JointState(), 'empty'),
    ('mismatched lengths', JointState(name=['spindle'], velocity=[100.0, 200.0]),
     'mismatched lengths'),
    ('a NaN', JointState(name=['spindle'], velocity=[math.nan]), 'nan'),
    ('an out-of-range speed', JointState(name=['spindle'], velocity=[1500.5]), 'valid range'),
    ('a position command', JointState(name=['spindle'], position=[1.0]), 'position'),
)


def test_each_malformed_command_is_refused_with_a_warning_counted_and_the_plant_goes_on(
        plants):
    plant = plants(**ENABLED)
    warnings = []
    plant.node.create_subscription(
        Log, '/rosout', lambda m: warnings.append(m.msg)
        if m.name == 'abb_simulator' and m.level == Log.WARN else None, LOG_QOS)
    system = connect(plant)
    plant.wait(lambda: plant.values(), 'a /diagnostics status')
    speed_cmd = plant.values()['speed_cmd']
    for refused, (what, msg, named) in enumerate(MALFORMED, start=1):
        seen, states = len(warnings), len(system.states)
        system.send(msg)
        plant.wait(lambda: len(warnings) > seen, f'a warning about {what}')
        assert named in warnings[-1] and COMMANDS_TOPIC in warnings[-1], (what, warnings[-1])
        plant.wait(lambda: plant.values().get('ros2_control refused') == str(refused),
                   f'{what} counted')
        values = plant.values()
        assert values['commands_refused'] == str(refused), what
        assert values['commands_accepted'] == '0' and values['speed_cmd'] == speed_cmd, what
        assert values['fault'] == '', what
        plant.wait(lambda: len(system.states) > states + 10, f'states after {what}')


def test_without_ros2_control_enabled_the_node_has_no_such_topics(plants):
    plant = plants(**FAST)
    joint_states = plant.collect(JointState, 'joint_states')
    plant.wait(lambda: joint_states and plant.values(), 'joint_states and a status')
    publishers = plant.sim.get_publisher_names_and_types_by_node('abb_simulator', '/')
    subscribers = plant.sim.get_subscriber_names_and_types_by_node('abb_simulator', '/')
    assert STATES_TOPIC not in dict(publishers)
    assert COMMANDS_TOPIC not in dict(subscribers)
    assert plant.node.count_subscribers(COMMANDS_TOPIC) == 0
    assert not [k for k in plant.values() if k.startswith('ros2_control')]


@pytest.mark.parametrize('topics, named', [
    ({'ros2_control.joint_states_topic': 'joint_states'}, 'ros2_control.joint_states_topic'),
    ({'ros2_control.joint_states_topic': COMMANDS_TOPIC}, 'ros2_control.joint_states_topic'),
    ({'ros2_control.joint_commands_topic': 'spindle/speed_cmd'},
     'ros2_control.joint_commands_topic'),
    ({'ros2_control.joint_commands_topic': 'not a topic'}, 'ros2_control.joint_commands_topic'),
])
def test_a_ros2_control_topic_that_is_taken_or_invalid_fails_the_start_up_naming_it(
        topics, named):
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    try:
        overrides = [Parameter(k, value=v) for k, v in {**ENABLED, **topics}.items()]
        with pytest.raises(ParamError, match=named):
            SimulatorNode(context=ctx, parameter_overrides=overrides)
    finally:
        rclpy.shutdown(context=ctx)

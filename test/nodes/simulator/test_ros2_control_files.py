"""The shipped ros2_control files agree with the simulator they drive.

config/ros2_control/abb_spindle.urdf.xacro (the ``<ros2_control>`` block of the topic-based
system) and abb_controllers.yaml (the controller manager's controllers): the plugin, its two
topics at the simulator's ``ros2_control.*`` defaults, the spindle joint's interfaces and limits
at the drive's, and a velocity controller at 1 kHz on that joint. The same URDF configures the
stand-in that test_ros2_control.py drives the simulator with over DDS.
"""

from pathlib import Path

import pytest
import yaml
from topic_based_system import PLUGIN, filled_urdf, ros2_control_block

from abb_ros.model.parameters.plant_spec import MOTOR_DEFAULTS
from abb_ros.nodes.ros.parameter_table import specs_for

FILES = Path(__file__).resolve().parents[3] / 'config' / 'ros2_control'
URDF = FILES / 'abb_spindle.urdf.xacro'


@pytest.fixture(scope='module')
def block():
    return ros2_control_block(URDF)


def test_the_urdf_names_the_topic_based_plugin_on_the_simulators_default_topics(block):
    specs = specs_for('simulator')
    hardware = block.find('hardware')
    assert hardware.findtext('plugin') == PLUGIN
    params = {p.get('name'): p.text for p in hardware.iter('param')}
    assert params == {
        'joint_commands_topic': specs['ros2_control.joint_commands_topic'].default,
        'joint_states_topic': specs['ros2_control.joint_states_topic'].default}


def test_the_spindle_is_commanded_in_velocity_within_the_drives_limit(block):
    max_speed = specs_for('simulator')['max_spindle_speed'].default
    (joint,) = block.findall('joint')
    assert joint.get('name') == 'spindle'
    (command,) = joint.findall('command_interface')
    assert command.get('name') == 'velocity'
    limits = {p.get('name'): float(p.text) for p in command.iter('param')}
    assert limits == {'min': -max_speed, 'max': max_speed}
    assert [s.get('name') for s in joint.findall('state_interface')] == ['position', 'velocity']


def test_the_urdf_joint_limits_are_the_drives_speed_and_motor_torque():
    (spindle,) = [j for j in filled_urdf(URDF).findall('joint') if j.get('name') == 'spindle']
    assert spindle.get('type') == 'continuous'
    limit = spindle.find('limit')
    assert float(limit.get('velocity')) == specs_for('simulator')['max_spindle_speed'].default
    assert float(limit.get('effort')) == pytest.approx(
        MOTOR_DEFAULTS['torque_constant'] * MOTOR_DEFAULTS['current_limit'])


def test_an_arg_given_replaces_the_default_topic():
    block = ros2_control_block(URDF, joint_commands_topic='/drive1/commands')
    params = {p.get('name'): p.text for p in block.find('hardware').iter('param')}
    assert params['joint_commands_topic'] == '/drive1/commands'


def test_the_controllers_run_a_velocity_controller_on_the_spindle_at_1_khz(block):
    config = yaml.safe_load((FILES / 'abb_controllers.yaml').read_text())
    manager = config['controller_manager']['ros__parameters']
    assert manager['update_rate'] == 1000
    assert manager['spindle_velocity_controller']['type'] == \
        'velocity_controllers/JointGroupVelocityController'
    assert manager['joint_state_broadcaster']['type'] == \
        'joint_state_broadcaster/JointStateBroadcaster'
    joints = config['spindle_velocity_controller']['ros__parameters']['joints']
    velocity_joints = [j.get('name') for j in block.findall('joint')
                       if 'velocity' in [c.get('name') for c in j.iter('command_interface')]]
    assert joints == velocity_joints == ['spindle']
    # the simulator publishes /joint_states (with the balls): the broadcaster keeps off it
    assert config['joint_state_broadcaster']['ros__parameters']['use_local_topics'] is True

"""The simulator node in torque mode over real rclpy and DDS: spindle/current_cmd refused
when non-finite, saturated beyond the current limit, and the motor torque in
joint_states.effort[0] (docs/torque_mode.md)."""

import math

import pytest
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from test_simulator_node import QOS, Plant

from abb_ros.model.dynamics.spindle import TorqueMotor

pytestmark = pytest.mark.ros


@pytest.fixture
def torque_plant():
    plant = Plant(real_time_factor=0.0, publish_rate_hz=100,
                  **{'imu.rate_hz': 100, 'spindle.mode': 'torque'})
    yield plant
    plant.close()


@pytest.mark.slow
def test_current_commands_are_refused_or_saturated_and_the_torque_is_the_effort(torque_plant):
    plant = torque_plant
    states = plant.collect(JointState, 'joint_states')
    plant.wait(lambda: states, 'joint_states')
    assert list(states[0].effort) == [0.0] * len(states[0].name)     # no current at start
    pub = plant.node.create_publisher(Float64, 'spindle/current_cmd', QOS)
    plant.wait(lambda: pub.get_subscription_count() > 0, 'current_cmd subscriber')
    for bad in (math.nan, math.inf, -math.inf):
        pub.publish(Float64(data=bad))
    plant.wait(lambda: plant.values().get('commands_refused') == '3', 'three refusals')
    assert plant.values()['spindle_mode'] == 'torque'
    pub.publish(Float64(data=5.0))                                    # beyond the 1 A limit
    plant.wait(lambda: plant.values().get('commands_saturated') == '1', 'a saturation')
    motor = TorqueMotor()
    plant.wait(lambda: states[-1].effort[0] != 0.0, 'effort under the command')
    seen = len(states)
    plant.wait(lambda: len(states) > seen + 20, 'joint_states under torque')
    driven = [m for m in states if m.effort[0] != 0.0]
    for m in driven:   # effort = K_t i(omega) with the command saturated and voltage-limited
        assert m.effort[0] == pytest.approx(motor.K_t * motor.current(m.velocity[0], 5.0),
                                            rel=1e-12)
    assert max(m.effort[0] for m in driven) <= motor.K_t * motor.I_max
    assert driven[-1].velocity[0] > driven[0].velocity[0]            # it accelerates


def test_headless_cdr_of_joint_states_with_effort_is_what_rclpy_serialises():
    """Live and headless agree in torque mode: the CDR the headless bags hold decodes to the
    JointState the live node publishes, effort included."""
    import numpy as np
    from rclpy.serialization import deserialize_message

    from abb_ros.io.wire import cdr, ros_messages
    from abb_ros.model.sensors.sampling import Sample
    y = np.arange(18, dtype=float) / 7.0
    sample = Sample(steps=12345, n=2, y=y, imu=None, effort=3.5e-3)
    stamp_ns, contents = ros_messages.sample_contents(sample, 100_000, None)
    n, position, velocity, effort = dict(contents)['joint_states']
    assert effort == [3.5e-3, 0.0, 0.0]
    _, headless = cdr.sample_cdr(sample, 100_000, None)
    decoded = deserialize_message(dict(headless)['joint_states'], JointState)
    assert decoded.header.stamp == ros_messages.time_msg(stamp_ns)
    assert decoded.name == ros_messages.joint_names(n)
    assert (list(decoded.position), list(decoded.velocity), list(decoded.effort)) == (
        position, velocity, effort)


def test_spindle_mode_switches_at_run_time_and_back():
    """spindle.mode set at run time applies at the next step: torque mode publishes efforts
    (0 A: no current command yet, so the rotor coasts down under friction and load); back in
    speed mode effort is empty again and the speed loop returns to the last speed command."""
    plant = Plant(real_time_factor=0.0, publish_rate_hz=100, **{'imu.rate_hz': 100})
    try:
        states = plant.collect(JointState, 'joint_states')
        plant.wait(lambda: states, 'joint_states')
        assert list(states[-1].effort) == []
        held = states[-1].velocity[0]
        assert all(r.successful for r in plant.set_params(**{'spindle.mode': 'torque'}))
        plant.wait(lambda: list(states[-1].effort) == [0.0, 0.0, 0.0], 'torque-mode efforts')
        seen = len(states)
        plant.wait(lambda: len(states) > seen + 20, 'joint_states in torque mode')
        assert states[-1].velocity[0] < held                            # coasting down
        assert all(r.successful for r in plant.set_params(**{'spindle.mode': 'speed'}))
        plant.wait(lambda: list(states[-1].effort) == [], 'speed mode again')
        plant.wait(lambda: abs(states[-1].velocity[0] - held) < 1e-3, 'back at the command')
    finally:
        plant.close()


def test_a_bad_spindle_mode_is_refused_naming_the_choices():
    plant = Plant(real_time_factor=0.0, publish_rate_hz=100, **{'imu.rate_hz': 100})
    try:
        result, = plant.set_params(**{'spindle.mode': 'current'})
        assert not result.successful
        assert 'spindle.mode' in result.reason and 'speed, torque' in result.reason
    finally:
        plant.close()

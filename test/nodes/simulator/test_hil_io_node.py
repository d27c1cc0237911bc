"""The simulator's HIL I/O over real rclpy and DDS: spindle/speed, shock, disc swap, sensor
faults on /diagnostics, visualization/markers.

Lockstep (paused, ~/step) so that every message is accounted for. Faults are shown against a
twin plant in another namespace with the same seed, stepped in the same lockstep: whatever
differs comes from the fault.
"""

import math

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped, TwistStamped
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger
from test_simulator_node import METAL_P, NOISE_OFF, Plant, stamp_ns
from visualization_msgs.msg import Marker, MarkerArray

from abb_ros.io.wire import ros_messages
from abb_ros.io.wire.markers import ROTOR_HEIGHT, marker_poses
from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.sensors.disturbances import apply_shock
from abb_ros.model.stability.equilibrium import balanced_equilibrium

pytestmark = pytest.mark.ros

LOCKSTEP = dict(start_paused=True, real_time_factor=0.0, publish_rate_hz=1000)
A, B = '/a', '/b'


@pytest.fixture
def plants():
    """Plant(**kwargs) factory; every plant is closed after the test."""
    made = []
    yield lambda **kwargs: made.append(Plant(**kwargs)) or made[-1]
    for plant in made:
        plant.close()


def step_both(plant, count, collected):
    """``count`` lockstep periods of both twins; waits for each period's joint_states."""
    for _ in range(count):
        for ns in (A, B):
            expected = len(collected[ns]) + 1
            assert plant.step(ns).success
            plant.wait(lambda: len(collected[ns]) >= expected, f'{ns} joint_states')


def wait_counts(plant, *expected):
    """Wait until each (messages, count) pair holds that many messages."""
    plant.wait(lambda: all(len(got) >= n for got, n in expected),
               'message counts ' + str([n for _, n in expected]))


def step_periods(plant, states, count):
    """Step a fresh lockstep plant ``count`` periods, each until its joint_states arrived."""
    for k in range(1, count + 1):
        assert plant.step().success
        plant.wait(lambda: len(states) >= k, f'period {k}')


def hil_status(plant, ns):
    return plant.diag.get(f'{ns}/abb_simulator: faults and disturbances')


def test_spindle_speed_arrives_with_every_state_sample_and_reads_the_speed(plants):
    plant = plants(**LOCKSTEP, **{'speed_sensor.pulses_per_rev': 12})
    states = plant.collect(JointState, 'joint_states')
    speeds = plant.collect(Float64, 'spindle/speed')
    for k in range(1, 101):
        assert plant.step().success
        plant.wait(lambda: len(states) >= k and len(speeds) >= k, f'period {k}')
    omega = np.array([m.velocity[0] for m in states])
    fg = np.array([m.data for m in speeds])
    assert len(fg) == len(omega) == 100
    read = fg > 0                              # 0 until two edges have been seen
    assert read[5:].all()
    # one tick of a 1 MHz timer at omega ~ 811 rad/s and 12 pulses is ~1.3 rad/s; jitter
    # 1 us std per edge: a few rad/s
    assert np.abs(fg[read] - omega[read]).max() < 10.0
    assert np.abs(fg[read] - omega[read]).mean() < 3.0


def test_a_shock_steps_the_published_deck_twist(plants):
    plant = plants(**dict(LOCKSTEP, publish_rate_hz=10000))   # a period of one step
    node = plant.sim
    twists = plant.collect(TwistStamped, 'deck/twist')
    for k in range(1, 11):
        assert plant.step().success
        plant.wait(lambda: len(twists) >= k, f'period {k}')
    step = [0.02, -0.01, 0.005, 0.3, -0.2, 0.5]
    (ok,) = plant.set_params(**{'disturbance.shock_velocity': step})
    assert ok.successful
    y0 = node.sim.y.copy()
    twin, calm = (Simulation(node.sim.params, node.sim.omega_cmd, node.sim.dt,
                             t0=node.sim.t, spindle=node.sim.spindle, y0=y)
                  for y in (apply_shock(y0, 2, step), y0))
    reply = plant.call(Trigger, '/abb_simulator/apply_shock', Trigger.Request())
    assert reply.success and 'shock' in reply.message
    # at the instant of the shock the twist jumps by exactly the step
    jump = (np.array(ros_messages.deck_pose_twist_content(node.sim.y, 2)[1])
            - np.array(ros_messages.deck_pose_twist_content(y0, 2)[1]))
    np.testing.assert_allclose(jump, step, rtol=0, atol=1e-14)
    seen = len(twists)
    assert plant.step().success
    plant.wait(lambda: len(twists) > seen, 'the period after the shock')
    assert stamp_ns(twists[-1]) == node.stamp_ns()
    every = node.sampler.publish_every
    twin.advance(every)
    calm.advance(every)
    t = twists[-1].twist
    published = np.array([t.linear.x, t.linear.y, t.linear.z,
                          t.angular.x, t.angular.y, t.angular.z])
    expected = np.array(ros_messages.deck_pose_twist_content(twin.y, 2)[1])
    np.testing.assert_allclose(published, expected, rtol=1e-12, atol=1e-15)
    # one period (0.1 ms) later the difference to the undisturbed plant is still the step,
    # give or take a tenth of a radian of the stiffest (tilt) modes' phase
    jump = published - np.array(ros_messages.deck_pose_twist_content(calm.y, 2)[1])
    np.testing.assert_allclose(jump, step, rtol=0.1)
    plant.wait(lambda: hil_status(plant, '') is not None and 'shocks' in {
        kv.key for kv in hil_status(plant, '').values}, 'faults and disturbances status')
    values = {kv.key: kv.value for kv in hil_status(plant, '').values}
    assert values['shocks'] == '1' and values['last_disturbance'].startswith('shock')


@pytest.mark.slow
def test_after_a_disc_swap_the_balls_re_settle_at_the_new_phi_star(plants):
    """P3 with metal washers; the disc becomes eps = 0.15 mm with its imbalance 30 deg on."""
    params = {f'drive.{k}': v for k, v in (('c', METAL_P.c), ('m', METAL_P.m))}
    plant = plants(**LOCKSTEP, **params, **{'disturbance.disc_eps': 0.15e-3,
                                                   'disturbance.disc_angle_deg': 30.0})
    states = plant.collect(JointState, 'joint_states')
    step_periods(plant, states, 3)
    before = states[-1]
    reply = plant.call(Trigger, '/abb_simulator/swap_disc', Trigger.Request())
    assert reply.success, reply.message
    assert plant.sim.get_parameter('drive.eps').value == 0.15e-3
    assert plant.step().success
    plant.wait(lambda: len(states) >= 4, 'the period after the swap')
    after = states[-1]
    delta = math.radians(30.0)
    dt = 1e-3
    # re-expressed: theta + delta, phi_i - delta (plus one period of motion)
    assert after.position[0] - before.position[0] == pytest.approx(
        delta + before.velocity[0] * dt, abs=1e-3)
    for i in (1, 2):
        assert after.position[i] - before.position[i] == pytest.approx(-delta, abs=0.02)
    plant.call(SetBool, '/abb_simulator/pause', SetBool.Request(data=False))
    plant.wait(lambda: stamp_ns(states[-1]) > 6_000_000_000, '6 s of simulated time',
               timeout=240)
    phi_star = np.degrees(balanced_equilibrium(plant.sim.drive).phi_star)
    settled = np.degrees(np.array(states[-1].position[1:]))
    np.testing.assert_allclose(np.sort(settled), np.sort(phi_star), atol=1.0)


@pytest.mark.slow
def test_imu_and_speed_faults_show_in_the_published_data_and_in_diagnostics(plants):
    plant = plants(namespaces=(A, B), **LOCKSTEP, seed=11)
    states = {ns: plant.collect(JointState, f'{ns}/joint_states') for ns in (A, B)}
    imu = {ns: plant.collect(Imu, f'{ns}/deck/imu') for ns in (A, B)}
    speed = {ns: plant.collect(Float64, f'{ns}/spindle/speed') for ns in (A, B)}
    step_both(plant, 20, states)
    wait_counts(plant, (imu[A], 20), (imu[B], 20))

    # dropout: no deck/imu, joint_states go on; listed in /diagnostics while active
    plant.set_params(A, **{'fault.imu_dropout': True})
    step_both(plant, 20, states)
    wait_counts(plant, (imu[B], 40))
    assert len(imu[A]) == 20 and len(states[A]) == 40
    plant.wait(lambda: hil_status(plant, A) is not None
               and hil_status(plant, A).level == DiagnosticStatus.WARN, 'WARN status')
    assert 'imu_dropout' in hil_status(plant, A).message
    plant.set_params(A, **{'fault.imu_dropout': False})
    step_both(plant, 5, states)
    wait_counts(plant, (imu[A], 25), (imu[B], 45))
    assert [m.linear_acceleration.x for m in imu[A][-5:]] == \
        [m.linear_acceleration.x for m in imu[B][-5:]]
    plant.wait(lambda: hil_status(plant, A).level == DiagnosticStatus.OK, 'OK again')

    # stuck: the last reading repeated
    plant.set_params(A, **{'fault.imu_stuck': True})
    step_both(plant, 10, states)
    wait_counts(plant, (imu[A], 35), (imu[B], 55))
    last_good = imu[A][-11]
    for m in imu[A][-10:]:
        assert (m.linear_acceleration.x, m.angular_velocity.z) == \
            (last_good.linear_acceleration.x, last_good.angular_velocity.z)
    assert len({m.linear_acceleration.x for m in imu[B][-10:]}) == 10
    plant.set_params(A, **{'fault.imu_stuck': False})

    # bias step: the readings shift by the step against the twin
    accel_step, gyro_step = [0.5, -0.25, 1.0], [0.01, 0.0, -0.02]
    plant.set_params(A, **{'fault.imu_accel_bias_step': accel_step,
                           'fault.imu_gyro_bias_step': gyro_step})
    step_both(plant, 10, states)
    wait_counts(plant, (imu[A], 45), (imu[B], 65))
    for a, b in zip(imu[A][-10:], imu[B][-10:]):
        va, vb = a.linear_acceleration, b.linear_acceleration
        np.testing.assert_allclose([va.x - vb.x, va.y - vb.y, va.z - vb.z], accel_step,
                                   atol=1e-9)
        wa, wb = a.angular_velocity, b.angular_velocity
        np.testing.assert_allclose([wa.x - wb.x, wa.y - wb.y, wa.z - wb.z], gyro_step,
                                   atol=1e-9)
    plant.wait(lambda: 'imu_accel_bias_step' in hil_status(plant, A).message, 'bias listed')

    # speed dropout: no spindle/speed; noise: the readings scatter by its std
    wait_counts(plant, (speed[A], 65), (speed[B], 65))
    plant.set_params(A, **{'fault.speed_dropout': True})
    step_both(plant, 10, states)
    wait_counts(plant, (speed[B], 75))
    assert len(speed[A]) == 65
    plant.set_params(A, **{'fault.speed_dropout': False, 'fault.speed_noise': 20.0})
    step_both(plant, 200, states)
    wait_counts(plant, (speed[A], 265), (speed[B], 275))
    diff = np.array([a.data - b.data for a, b in zip(speed[A][-200:], speed[B][-200:])])
    # the std of n Gaussian draws scatters by 1/sqrt(2 (n - 1)) of the true one: four of those
    assert np.std(diff) == pytest.approx(20.0, rel=4 / np.sqrt(2 * (len(diff) - 1)))
    plant.wait(lambda: 'speed_noise' in hil_status(plant, A).message, 'noise listed')
    assert hil_status(plant, B).level == DiagnosticStatus.OK


def _euler_from_quaternion(o):
    """(alpha, beta, gamma) of R = Rz(gamma) Rx(alpha) Ry(beta) from a unit quaternion."""
    x, y, z, w = o.x, o.y, o.z, o.w
    r01 = 2 * (x * y - z * w)
    r11 = 1 - 2 * (x * x + z * z)
    r20 = 2 * (x * z - y * w)
    r21 = 2 * (y * z + x * w)
    r22 = 1 - 2 * (x * x + y * y)
    return math.asin(r21), math.atan2(-r20, r22), math.atan2(-r01, r11)


def test_markers_show_deck_rotor_and_balls_at_their_rate_with_the_deck_exaggerated(
        plants):
    k = 100.0
    plant = plants(**LOCKSTEP, **NOISE_OFF, **{'visualization.rate_hz': 100.0,
                                                      'visualization.exaggeration': k})
    states = plant.collect(JointState, 'joint_states')
    poses = plant.collect(PoseStamped, 'deck/pose')
    markers = plant.collect(MarkerArray, 'visualization/markers')
    for i in range(1, 51):
        assert plant.step().success
        plant.wait(lambda: len(states) >= i and len(poses) >= i, f'period {i}')
    plant.wait(lambda: len(markers) >= 5, 'markers at 100 Hz')
    plant.spin_for(0.2)
    # 50 periods of 1 ms at 100 Hz: slots 10, 20, ... 50 ms (step 0 went out before we
    # subscribed)
    assert [stamp_ns(m.markers[0]) for m in markers] == [i * 10_000_000 for i in range(1, 6)]
    state_at = {stamp_ns(m): m for m in states}
    pose_at = {stamp_ns(m): m for m in poses}
    drive = plant.sim.drive
    for array in markers:
        assert len(array.markers) == 2 + drive.n
        assert [m.type for m in array.markers] == [Marker.CUBE, Marker.CYLINDER] + \
            [Marker.SPHERE] * drive.n
        assert {m.header.frame_id for m in array.markers} == {'base'}
        js, pose = state_at[stamp_ns(array.markers[0])], pose_at[stamp_ns(array.markers[0])]
        y = np.zeros(2 * (7 + drive.n))
        y[0] = js.position[0]
        y[1:4] = pose.pose.position.x, pose.pose.position.y, pose.pose.position.z
        y[4:7] = _euler_from_quaternion(pose.pose.orientation)
        y[7:7 + drive.n] = js.position[1:]
        for m, (kind, expected, scale) in zip(array.markers, marker_poses(y, drive, k)):
            got = (m.pose.position.x, m.pose.position.y, m.pose.position.z,
                   m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z,
                   m.pose.orientation.w)
            np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)
        # rigid on the exaggerated deck: the rotor's centre is ROTOR_HEIGHT / 2 from k C
        rotor = array.markers[1].pose.position
        centre = k * np.array(y[1:4])
        assert np.linalg.norm(np.array([rotor.x, rotor.y, rotor.z]) - centre) == \
            pytest.approx(ROTOR_HEIGHT / 2, rel=1e-9)


def test_markers_off_at_rate_zero(plants):
    plant = plants(**LOCKSTEP, **{'visualization.rate_hz': 0.0})
    states = plant.collect(JointState, 'joint_states')
    markers = plant.collect(MarkerArray, 'visualization/markers')
    step_periods(plant, states, 30)
    plant.spin_for(0.2)
    assert markers == []

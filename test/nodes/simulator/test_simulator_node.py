"""The simulator node over real rclpy and DDS: topics, rates, kinematic consistency, the
P1 -> P3 spin-up of Section 5, bad input, lockstep, reset, determinism.

Each test has its own rclpy Context; the simulator spins in a background thread (or runs
as a subprocess for the real-time test) and a test 'controller' node talks to it over DDS.
Waits have deadlines; nothing is mocked.
"""

import math
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped, TwistStamped
from rcl_interfaces.srv import SetParameters
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from abb_ros.model.parameters.params import DriveParams
from abb_ros.nodes.ros.taps import Taps
from abb_ros.nodes.simulator.node import SimulatorNode, make_executor

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[3]
DEADLINE_S = 20.0  # generous: the machine is shared; a healthy run takes a fraction of it
QOS = QoSProfile(depth=10000, reliability=ReliabilityPolicy.RELIABLE)
TABLE1 = DriveParams()
METAL_P = DriveParams(c=0.66, m=0.03 * 0.026)  # Fig. 7(b) points P1-P3: metal, mbar = 0.03
NOISE_OFF = {f'imu.{k}': 0.0 for k in (
    'accel_noise_density', 'accel_bias', 'accel_bias_random_walk', 'gyro_noise_density',
    'gyro_bias', 'gyro_bias_random_walk')}


def stamp_ns(msg) -> int:
    s = msg.header.stamp if hasattr(msg, 'header') else msg.clock
    return s.sec * 1_000_000_000 + s.nanosec


class Plant:
    """Simulator node(s) spinning in a background thread plus a test 'controller' node."""

    def __init__(self, namespaces=('',), **params):
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        overrides = [Parameter(k, value=v) for k, v in params.items()]
        self.sims = [SimulatorNode(context=self.ctx, namespace=ns or None,
                                   parameter_overrides=overrides) for ns in namespaces]
        self.sim = self.sims[0]
        self.node = Node('test_controller', context=self.ctx)
        self.test_executor = SingleThreadedExecutor(context=self.ctx)
        self.test_executor.add_node(self.node)
        self.sim_executor = make_executor(self.ctx)
        for sim in self.sims:
            self.sim_executor.add_node(sim)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        self.diag = {}
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, QOS)

    def _spin(self):
        while not self._stop.is_set() and self.ctx.ok():
            self.sim_executor.spin_once(timeout_sec=0.05)

    def close(self):
        self._stop.set()
        self._thread.join(timeout=10)
        self.sim_executor.shutdown()   # releases the nodes' handles: their endpoints go away
        for sim in self.sims:
            sim.destroy_node()
        self.node.destroy_node()
        rclpy.shutdown(context=self.ctx)

    def _on_diag(self, msg):
        for status in msg.status:
            self.diag[status.name] = status

    def status(self, ns=''):
        return self.diag.get(f'{ns}/abb_simulator: simulation')

    def values(self, ns=''):
        status = self.status(ns)
        return {kv.key: kv.value for kv in status.values} if status else {}

    def wait(self, predicate, what, timeout=DEADLINE_S):
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > deadline:
                pytest.fail(f'timed out after {timeout} s waiting for {what}')
            self.test_executor.spin_once(timeout_sec=0.02)

    def spin_for(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.test_executor.spin_once(timeout_sec=0.02)

    def drain(self, got, quiet=0.3):
        """Spin until nothing was added to ``got`` for ``quiet`` s: the publishers keep 1000
        messages for reliable subscribers, so a loaded test process can be behind."""
        self.wait(lambda: self._quiet_for(got, quiet), f'a quiet {quiet} s')

    def _quiet_for(self, got, quiet):
        n = len(got)
        self.spin_for(quiet)
        return len(got) == n

    def collect(self, kind, topic):
        got = []
        self.node.create_subscription(kind, topic, got.append, QOS)
        return got

    def call(self, kind, name, request):
        client = self.node.create_client(kind, name)
        self.wait(client.service_is_ready, f'service {name}')
        future = client.call_async(request)
        self.wait(future.done, f'reply of {name}')
        return future.result()

    def set_params(self, ns='', **params):
        req = SetParameters.Request(
            parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in params.items()])
        return self.call(SetParameters, f'{ns}/abb_simulator/set_parameters', req).results

    def pause(self, paused, ns=''):
        assert self.call(SetBool, f'{ns}/abb_simulator/pause', SetBool.Request(data=paused))\
            .success

    def step(self, ns=''):
        return self.call(Trigger, f'{ns}/abb_simulator/step', Trigger.Request())

    def command(self, omega, ns=''):
        pub = self.node.create_publisher(Float64, f'{ns}/spindle/speed_cmd', QOS)
        self.wait(lambda: pub.get_subscription_count() > 0, 'speed_cmd subscriber')
        pub.publish(Float64(data=float(omega)))
        return pub


@pytest.fixture
def plant_factory():
    plants = []

    def make(**kwargs):
        plants.append(Plant(**kwargs))
        return plants[-1]

    yield make
    for p in plants:
        p.close()


# ---- real time, as a separate process ---------------------------------------------------------

class Published:
    """What the writers of ``topics`` published: the source timestamp of each message.

    Counted by the writer's source timestamps (message info, taken in batches through Taps),
    not by when this process gets round to each message: a reader slowed by other load on
    the machine (550-900 Hz counted by callbacks beside a busy process while a separate
    subscriber received 1000 Hz) only delays the taking.
    """

    def __init__(self, node, executor, topics):
        self.executor = executor
        self.taps = Taps(node)
        self.subs = {topic: self.taps.subscribe(kind, topic, QOS)
                     for topic, kind in topics.items()}
        self.sources = {topic: [] for topic in topics}

    def spin_for(self, seconds: float) -> None:
        """Spin the executor and take every message queued, for ``seconds``."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.02)
            for topic, sub in self.subs.items():
                while (taken := Taps.take(sub)) is not None:
                    self.sources[topic].append(taken[1]['source_timestamp'])

    def rate(self, topic: str, start_ns: int, end_ns: int) -> float:
        """Messages of ``topic`` published in [start_ns, end_ns) of the wall clock, per s."""
        count = sum(start_ns <= t < end_ns for t in self.sources[topic])
        return count / ((end_ns - start_ns) * 1e-9)

    def destroy(self) -> None:
        """Destroy the subscriptions."""
        self.taps.destroy()


def simulation_statuses(diagnostics: list, start_ns: int, end_ns: int, ns: str):
    """The first and last simulation status of the plant stamped in [start_ns, end_ns) of the
    wall clock: (stamp [ns], values) each."""
    inside = [(stamp_ns(msg), {kv.key: kv.value for kv in status.values})
              for msg in diagnostics for status in msg.status
              if status.name == f'{ns}/abb_simulator: simulation'
              and start_ns <= stamp_ns(msg) < end_ns]
    return inside[0], inside[-1]


# Real time on a shared 2-core machine: a burst of load from elsewhere can starve the node
# for part of the window, so a failure is retried (pytest-rerunfailures, pinned). Whether
# this machine runs the plant at full speed is measured in benchmarks/bench_simulator_node.py;
# here each topic's rate is checked against the real-time factor the plant itself reports
# (1.00 on a machine that keeps up): a message lost, or one too many, fails either way.
@pytest.mark.slow
@pytest.mark.flaky(reruns=2)
def test_topics_arrive_at_their_rates_with_frames_names_and_units_in_real_time(tmp_path):
    ns = '/rt'
    log = open(tmp_path / 'simulator.log', 'w+')
    proc = subprocess.Popen(
        [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args', '-r', f'__ns:={ns}',
         '-p', 'imu.rate_hz:=500'],
        cwd=ROOT, stdout=log, stderr=subprocess.STDOUT)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = Node('rate_probe', context=ctx)
    executor = make_executor(ctx)
    executor.add_node(node)
    topics = {'joint_states': JointState, 'deck/pose': PoseStamped,
              'deck/twist': TwistStamped, 'deck/imu': Imu}
    published = Published(node, executor, {f'{ns}/{t}': kind for t, kind in topics.items()})
    try:
        typed = {}
        clocks, diagnostics = [], []
        node.create_subscription(Clock, '/clock', clocks.append, 10)
        node.create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 100)
        deadline = time.monotonic() + 60  # includes the node's numba compile at start-up
        while not all(published.sources.values()):
            assert proc.poll() is None, (tmp_path / 'simulator.log').read_text()
            assert time.monotonic() < deadline, 'no data from the simulator'
            published.spin_for(0.05)
        # Let start-up transients (DDS matching, first ticks) pass, then count over 3 s of
        # the wall clock (the clock of the source timestamps), and take what was published
        # in the window and is still on its way.
        published.spin_for(1.0)
        w0 = time.time_ns()
        published.spin_for(4.0)
        w1 = time.time_ns()
        published.spin_for(1.0)
        # The plant's own statuses (1 Hz) in the window: its sim time against their wall
        # stamps, and how many messages it says it published between them.
        (t0, first), (t1, last) = simulation_statuses(diagnostics, w0, w1, ns)
        factor = (float(last['sim_time']) - float(first['sim_time'])) / ((t1 - t0) * 1e-9)
        slips = int(last['slips']) - int(first['slips'])
        pace = f'the plant ran at {factor:.3f} of real time ({slips} slips)'
        print(f'real time: {pace}')
        assert factor > 0.5, f'{pace}: far behind'
        expected = {'joint_states': 1000, 'deck/pose': 1000, 'deck/twist': 1000,
                    'deck/imu': 500}
        for topic, rate in expected.items():
            # Every message the plant counted as published between its two statuses arrived
            # (a few either side: a status's stamp and its counts are not taken at one instant).
            sent = int(last[f'published {topic}']) - int(first[f'published {topic}'])
            got = round(published.rate(f'{ns}/{topic}', t0, t1) * (t1 - t0) * 1e-9)
            assert abs(got - sent) <= 3, (topic, f'{got} arrived of {sent} published', pace)
            # Each rate within 5 % over a few seconds, at the plant's pace (its slips drop
            # stamps, so their messages, beyond max_stamp_lag).
            measured = published.rate(f'{ns}/{topic}', w0, w1)
            assert measured == pytest.approx(rate * min(factor, 1.0), rel=0.05), \
                (topic, measured, pace)
        # Then the contents, by typed subscriptions (deserialising 3.5 kHz of messages in the
        # same Python executor as the counters would slow the counting down).
        for topic, kind in topics.items():
            node.create_subscription(kind, f'{ns}/{topic}',
                                     lambda m, t=topic: typed.__setitem__(t, m), 10)
        deadline = time.monotonic() + 10
        while len(typed) < len(topics):
            assert time.monotonic() < deadline, f'typed messages: only {sorted(typed)}'
            executor.spin_once(timeout_sec=0.05)
        wall_ns = time.time_ns()

        js, pose = typed['joint_states'], typed['deck/pose']
        assert js.name == ['spindle', 'ball_1', 'ball_2']
        # Initial speed is P3's wbar = 2.7 with the Table 1 omega0, in rad/s.
        assert js.velocity[0] == pytest.approx(2.7 * TABLE1.omega0, rel=1e-9)
        assert pose.header.frame_id == 'base'
        assert typed['deck/twist'].header.frame_id == 'deck'
        imu = typed['deck/imu']
        assert imu.header.frame_id == 'deck' and imu.orientation_covariance[0] == -1.0
        # Default accelerometer density 1.5e-3 m/s^2/sqrt(Hz) at 500 Hz: variance d^2 f.
        assert imu.linear_acceleration_covariance[0] == pytest.approx(1.5e-3 ** 2 * 500)
        # Wall-clock time base: stamps follow the wall clock, no /clock, whole steps.
        assert abs(stamp_ns(js) - wall_ns) < 0.5e9
        assert stamp_ns(js) % 50_000 == 0 and not clocks

        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=15) == 0
        log.seek(0)
        output = log.read()
        assert 'Traceback' not in output, output
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        published.destroy()
        node.destroy_node()
        rclpy.shutdown(context=ctx)
        log.close()


# ---- lockstep and as fast as possible, in process -------------------------------------------

def quat_matrix(q):
    x, y, z, w = q.x, q.y, q.z, q.w
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def test_pose_twist_and_imu_agree_at_the_mounting_point(plant_factory):
    mount = [0.02, -0.01, 0.003]
    plant = plant_factory(start_paused=True, real_time_factor=0.0, publish_rate_hz=5000,
                          **{'imu.rate_hz': 5000, 'imu.position': mount}, **NOISE_OFF)
    poses = plant.collect(PoseStamped, 'deck/pose')
    twists = plant.collect(TwistStamped, 'deck/twist')
    imus = plant.collect(Imu, 'deck/imu')
    count = 40
    for _ in range(count):
        assert plant.step().success
    plant.wait(lambda: min(len(poses), len(twists), len(imus)) >= count, 'lockstep samples')
    h = 2e-4  # one publish period at 5 kHz
    assert np.all(np.diff([stamp_ns(m) for m in poses[-count:]]) == 200_000)
    pos = np.array([[m.pose.position.x, m.pose.position.y, m.pose.position.z]
                    for m in poses[-count:]])
    rots = [quat_matrix(m.pose.orientation) for m in poses[-count:]]
    point = np.array([p + r @ mount for p, r in zip(pos, rots)])
    acc_fd = (point[2:] - 2 * point[1:-1] + point[:-2]) / h ** 2
    acc_fd_deck = np.array([r.T @ a for r, a in zip(rots[1:-1], acc_fd)])
    by_stamp = {stamp_ns(m): m for m in imus}
    imu_acc = np.array([[by_stamp[stamp_ns(m)].linear_acceleration.x,
                         by_stamp[stamp_ns(m)].linear_acceleration.y,
                         by_stamp[stamp_ns(m)].linear_acceleration.z]
                        for m in poses[-count:][1:-1]])
    scale = np.max(np.abs(imu_acc))
    assert scale > 1.0  # the deck is shaking at ~0.3 mm, 811 rad/s: m/s^2 at least
    # Central second difference: error ~ (w h)^2 / 12 with w <= ~1000 rad/s, h = 2e-4 s:
    # ~0.3 % of the amplitude; 2 % leaves room for the higher deck modes.
    np.testing.assert_allclose(imu_acc, acc_fd_deck, atol=0.02 * scale)

    lin = np.array([[m.twist.linear.x, m.twist.linear.y, m.twist.linear.z]
                    for m in twists[-count:]])
    vel_fd = (pos[2:] - pos[:-2]) / (2 * h)
    vel_fd_deck = np.array([r.T @ v for r, v in zip(rots[1:-1], vel_fd)])
    # Central first difference: ~(w h)^2 / 6 ~ 0.7 %.
    np.testing.assert_allclose(lin[1:-1], vel_fd_deck, atol=0.02 * np.max(np.abs(lin)))
    ang = np.array([[m.twist.angular.x, m.twist.angular.y, m.twist.angular.z]
                    for m in twists[-count:]])
    gyro = np.array([[by_stamp[stamp_ns(m)].angular_velocity.x,
                      by_stamp[stamp_ns(m)].angular_velocity.y,
                      by_stamp[stamp_ns(m)].angular_velocity.z] for m in twists[-count:]])
    np.testing.assert_array_equal(gyro, ang)  # noise off: the gyro is Eq. (10) exactly
    # Eq. (10) against the rotation: skew(R^T dR/dt).
    for k in range(1, count - 1):
        skew = rots[k].T @ (rots[k + 1] - rots[k - 1]) / (2 * h)
        w_fd = [skew[2, 1], skew[0, 2], skew[1, 0]]
        np.testing.assert_allclose(ang[k], w_fd, atol=0.02 * np.max(np.abs(ang)) + 1e-6)


def test_spin_up_from_p1_to_p3_moves_balls_from_imbalance_side_to_phi_star_as_rbar_falls(
        plant_factory):
    omega0 = METAL_P.omega0
    plant = plant_factory(real_time_factor=0.0, publish_rate_hz=100, **{
        'imu.rate_hz': 100, 'drive.c': METAL_P.c, 'drive.m': METAL_P.m,
        'spindle.initial_speed': 0.8 * omega0})
    states = plant.collect(JointState, 'joint_states')
    poses = plant.collect(PoseStamped, 'deck/pose')

    def rbar(m):
        p = m.pose.position
        return math.sqrt(p.x ** 2 + p.y ** 2 + p.z ** 2) / METAL_P.R

    # P1 (wbar = 0.8): 1 s is enough for the balls to gather on the imbalance side.
    plant.wait(lambda: states and stamp_ns(states[-1]) >= 1.0e9, '1 s at P1')
    phi_p1 = np.degrees(states[-1].position[1:])
    rbar_p1 = max(rbar(m) for m in poses[-20:])
    assert np.all(np.abs(phi_p1) < 90.0), phi_p1  # |phi| < 90 deg: with the imbalance G
    t_cmd = stamp_ns(states[-1])
    plant.command(2.7 * omega0)
    plant.wait(lambda: stamp_ns(states[-1]) >= t_cmd + 6.0e9, '6 s after the spin-up command')
    final = states[-1]
    assert final.velocity[0] == pytest.approx(2.7 * omega0, rel=1e-6)
    phi = np.degrees(np.angle(np.exp(1j * np.asarray(final.position[1:]))))
    # Eq. (26) with n = 2: cos phi* = -M eps / (2 m R) -> 106.1 deg; the paper reads "about
    # +-106 deg" off Fig. 11(b). 2 deg allows the residual transient after 6 s.
    phi_star = math.degrees(math.acos(-METAL_P.M * METAL_P.eps / (2 * METAL_P.m * METAL_P.R)))
    assert sorted(phi) == pytest.approx([-phi_star, phi_star], abs=2.0)
    rbar_p3 = max(rbar(m) for m in poses[-20:])
    # Balanced: the centre's displacement falls by orders of magnitude (Fig. 11(a) -> 0).
    assert rbar_p3 < 0.01 * rbar_p1, (rbar_p1, rbar_p3)


@pytest.mark.slow
def test_bad_speed_commands_are_refused_and_integration_goes_on(plant_factory):
    plant = plant_factory(real_time_factor=0.0, publish_rate_hz=100, **{'imu.rate_hz': 100})
    states = plant.collect(JointState, 'joint_states')
    plant.wait(lambda: states, 'joint_states')
    initial = 2.7 * TABLE1.omega0
    for bad in (math.nan, math.inf, -1.0, 1500.5):  # max_spindle_speed defaults to 1500
        pub = plant.command(bad)
    plant.wait(lambda: plant.values().get('commands_refused') == '4', 'four refusals')
    assert plant.values()['commands_accepted'] == '0'
    assert plant.status().level == DiagnosticStatus.WARN or plant.status().level == \
        DiagnosticStatus.OK
    seen = len(states)
    plant.wait(lambda: len(states) > seen + 50, 'joint_states after the bad commands')
    assert all(m.velocity[0] == pytest.approx(initial, rel=1e-12) for m in states[seen:])
    pub.publish(Float64(data=300.0))
    plant.wait(lambda: plant.values().get('commands_accepted') == '1', 'a good command')
    plant.wait(lambda: abs(states[-1].velocity[0] - 300.0) < 1e-3, 'speed reaches 300 rad/s')


def test_refused_parameter_change_names_the_parameter_and_its_range(plant_factory):
    plant = plant_factory(real_time_factor=0.0, publish_rate_hz=100, **{'imu.rate_hz': 100})
    states = plant.collect(JointState, 'joint_states')
    plant.wait(lambda: states, 'joint_states')
    (j_y,) = plant.set_params(**{'drive.J_y': 1e-5})  # inside its ROS range, not = J_x
    assert not j_y.successful
    assert "'drive.J_y'" in j_y.reason and 'equal to J_x = 1.46e-06 kg m^2' in j_y.reason
    (rate,) = plant.set_params(publish_rate_hz=7)
    assert not rate.successful and 'divisor of integration_rate_hz' in rate.reason
    (pos,) = plant.set_params(**{'imu.position': [0.0, 1.0]})
    assert not pos.successful and 'imu.position' in pos.reason
    (neg,) = plant.set_params(**{'drive.m': -1.0})  # outside the descriptor's range
    assert not neg.successful
    assert plant.sim.get_parameter('drive.k').value == TABLE1.k  # nothing changed
    # An accepted change applies at a step boundary: omega0 follows k, so wbar moves.
    (ok,) = plant.set_params(**{'drive.k': 4 * TABLE1.k})
    assert ok.successful
    plant.wait(lambda: plant.values().get('wbar') and
               float(plant.values()['wbar']) == pytest.approx(1.35, rel=1e-9),
               'wbar = 2.7 / 2 after k x 4')
    seen = len(states)
    plant.wait(lambda: len(states) > seen + 20, 'joint_states after the changes')


def test_state_leaving_the_envelope_stops_with_error_and_reset_recovers(plant_factory):
    plant = plant_factory(real_time_factor=0.0, publish_rate_hz=1000)
    states = plant.collect(JointState, 'joint_states')
    imus = plant.collect(Imu, 'deck/imu')
    plant.wait(lambda: states, 'joint_states')
    # k = 1e9 N/m is a valid washer, but its mode (1.5e5 rad/s) is far beyond what the
    # 10 kHz RK4 can resolve (w dt = 15 > 2.8): the state explodes within a few steps.
    assert plant.set_params(**{'drive.k': 1e9})[0].successful
    plant.wait(lambda: plant.status() and plant.status().level == DiagnosticStatus.ERROR,
               'ERROR on /diagnostics')
    assert 'envelope' in plant.status().message or 'non-finite' in plant.status().message
    plant.drain(states)
    frozen = len(states)
    plant.spin_for(0.3)  # a bounded look: nothing more may come while faulted
    assert len(states) == frozen
    assert all(np.all(np.isfinite(m.position)) and np.all(np.isfinite(m.velocity))
               for m in states)
    assert all(math.isfinite(m.linear_acceleration.x) for m in imus)
    assert not plant.step().success  # not paused, and faulted
    assert plant.set_params(**{'drive.k': TABLE1.k})[0].successful
    last = stamp_ns(states[-1])
    reply = plant.call(Trigger, '/abb_simulator/reset', Trigger.Request())
    assert reply.success and 'cleared' in reply.message
    plant.wait(lambda: len(states) > frozen + 10, 'joint_states after ~/reset')
    assert stamp_ns(states[frozen]) > last
    plant.wait(lambda: plant.status().level == DiagnosticStatus.OK, 'OK after reset')


def test_pause_and_step_advance_exactly_one_publish_period_in_lockstep(plant_factory):
    plant = plant_factory(start_paused=True, real_time_factor=0.0, publish_rate_hz=1000)
    states = plant.collect(JointState, 'joint_states')
    clocks = plant.collect(Clock, '/clock')
    plant.spin_for(0.3)  # a bounded look: a paused plant publishes nothing
    assert states == []
    for k in range(1, 6):
        reply = plant.step()
        assert reply.success
        plant.wait(lambda: len(states) == k and len(clocks) >= k, f'step {k}')
        # Exactly one period of 1 ms per step, stamped in integer nanoseconds.
        assert stamp_ns(states[-1]) == k * 1_000_000
        assert stamp_ns(clocks[-1]) == k * 1_000_000
    plant.pause(False)
    assert not plant.step().success  # running: ~/step is refused
    plant.wait(lambda: len(states) > 100, 'free running after resume')
    plant.pause(True)
    plant.drain(states)
    n_paused = len(states)
    plant.spin_for(0.3)
    assert len(states) == n_paused
    stamps = [stamp_ns(m) for m in states]
    assert np.all(np.diff(stamps) == 1_000_000)


def test_reset_restores_the_initial_state_and_clock_never_goes_backwards(plant_factory):
    plant = plant_factory(start_paused=True, real_time_factor=0.0, publish_rate_hz=1000)
    states = plant.collect(JointState, 'joint_states')
    clocks = plant.collect(Clock, '/clock')
    plant.pause(False)
    plant.wait(lambda: len(states) > 300, 'a run')
    plant.pause(True)
    plant.spin_for(0.2)
    before = len(states)
    # A command that moves the spindle away from its initial speed.
    plant.command(400.0)
    plant.pause(False)
    plant.wait(lambda: abs(states[-1].velocity[0] - 400.0) < 1.0, 'speed 400 rad/s')
    plant.pause(True)
    assert plant.call(Trigger, '/abb_simulator/reset', Trigger.Request()).success
    plant.drain(states)
    n = len(states)
    assert plant.step().success
    plant.wait(lambda: len(states) == n + 1, 'first period after reset')
    after = states[-1]
    # One 1 ms period from the Section 5 state: balls within 1 deg of +-60 deg, spindle at
    # the initial speed, time still going forward.
    assert np.degrees(after.position[1:]) == pytest.approx([60.0, -60.0], abs=1.0)
    assert after.velocity[0] == pytest.approx(2.7 * TABLE1.omega0, rel=1e-9)
    assert before < n
    assert np.all(np.diff([stamp_ns(m) for m in states]) > 0)
    assert np.all(np.diff([stamp_ns(m) for m in clocks]) > 0)


def test_same_seed_parameters_and_commands_give_identical_data(plant_factory):
    plant = plant_factory(namespaces=('/a', '/b'), start_paused=True, real_time_factor=0.0,
                          publish_rate_hz=100, seed=5, **{'imu.rate_hz': 100})
    data = {ns: (plant.collect(JointState, f'{ns}/joint_states'),
                 plant.collect(Imu, f'{ns}/deck/imu')) for ns in ('/a', '/b')}
    for ns in data:
        plant.command(2.0 * TABLE1.omega0, ns)
    for ns in data:
        plant.wait(lambda ns=ns: plant.values(ns).get('commands_accepted') == '1',
                   f'{ns} took the command')
    for ns in data:
        plant.pause(False, ns)
    plant.wait(lambda: all(js and stamp_ns(js[-1]) >= 2.0e9 for js, _ in data.values()),
               '2 s of simulated time on both')

    def table(msgs, fields):
        return {stamp_ns(m): fields(m) for m in msgs}

    js_a, js_b = (table(data[ns][0], lambda m: (list(m.position), list(m.velocity)))
                  for ns in ('/a', '/b'))
    imu_a, imu_b = (table(data[ns][1], lambda m: (
        m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z,
        m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z))
        for ns in ('/a', '/b'))
    common = sorted(set(js_a) & set(js_b) & set(imu_a) & set(imu_b))
    assert len(common) >= 150
    # Bit for bit: same kernel, same inputs, same generator.
    assert [js_a[t] for t in common] == [js_b[t] for t in common]
    assert [imu_a[t] for t in common] == [imu_b[t] for t in common]
    # ... and not trivially: the spindle really changed speed, the IMU really is noisy.
    assert js_a[common[-1]][1][0] == pytest.approx(2.0 * TABLE1.omega0, rel=1e-6)
    assert len({imu_a[t][0] for t in common}) == len(common)


def test_subscribers_coming_and_going_leave_the_plant_running(plant_factory):
    plant = plant_factory(real_time_factor=0.0, publish_rate_hz=1000)
    for _ in range(5):
        got = []
        sub = plant.node.create_subscription(Imu, 'deck/imu', got.append, QOS)
        plant.wait(lambda: len(got) > 20, 'imu data')
        plant.node.destroy_subscription(sub)
    states = plant.collect(JointState, 'joint_states')
    plant.wait(lambda: len(states) > 50, 'joint_states still flowing')
    assert plant.status() is None or plant.status().level != DiagnosticStatus.ERROR


def test_a_change_of_n_waits_for_reset(plant_factory):
    plant = plant_factory(start_paused=True, real_time_factor=0.0, publish_rate_hz=1000)
    states = plant.collect(JointState, 'joint_states')
    assert plant.set_params(**{'drive.n': 3})[0].successful
    assert plant.step().success
    plant.wait(lambda: len(states) == 1, 'a step with the old n')
    assert states[-1].name == ['spindle', 'ball_1', 'ball_2']
    assert plant.call(Trigger, '/abb_simulator/reset', Trigger.Request()).success
    assert plant.step().success
    plant.wait(lambda: len(states) == 2, 'a step after ~/reset')
    assert states[-1].name == ['spindle', 'ball_1', 'ball_2', 'ball_3']
    # n = 3 starts from the two fanned groups of initial.default_phi0: +60, -60, +61 deg.
    assert np.degrees(states[-1].position[1:]) == pytest.approx([60.0, -60.0, 61.0], abs=1.0)


@pytest.mark.parametrize('rate_hz, warned', [(2000, True), (10000, False)])
@pytest.mark.slow
def test_contact_at_a_step_outside_the_verified_range_is_a_warning(plant_factory, rate_hz,
                                                                   warned):
    """Steel balls touching, 2 kHz steps (5e-4 s, beyond the tested 1e-5..2e-4 s): the plant
    runs and /diagnostics says so (WARN); at the default 10 kHz nothing is said."""
    plant = plant_factory(real_time_factor=0.0, publish_rate_hz=100,
                          integration_rate_hz=rate_hz,
                          **{'drive.r_ball': 0.0023, 'drive.contact_E': 2e11})
    plant.wait(lambda: plant.status() is not None and float(plant.values()['sim_time']) > 0,
               'a simulation status')
    status = plant.status()
    assert ('contact impacts\' accuracy is verified' in status.message) is warned
    if warned:
        assert status.level >= DiagnosticStatus.WARN
        assert '0.0005 s outside 1e-05..0.0002 s' in status.message

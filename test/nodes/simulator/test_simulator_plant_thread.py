"""The simulator's plant on its own thread, and joint_states_throttle, over real rclpy and DDS.

The plant is paced by its own thread (runtime/plant_thread.py), not by the executor: it keeps
publishing while no executor spins the node, and a callback of the node holds the plant's
lock (tested through the node's services in test_simulator_node.py and
test_simulator_time.py). ``ABB_ROS_PACING=timer`` brings back the executor's timer;
anything else is refused in one line. ``joint_states_throttle`` carries exactly the
``joint_states`` messages that open a slot of 1 / ``joint_states_throttle_hz``.
"""

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
import test_simulator_node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from test_simulator_node import stamp_ns

from abb_ros.nodes.simulator.node import PACING_ENV, SimulatorNode

pytestmark = pytest.mark.ros
plant_factory = test_simulator_node.plant_factory   # the fixture, shared

ROOT = Path(__file__).resolve().parents[3]


def alone(**params):
    """A simulator node in its own context that no executor spins."""
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = SimulatorNode(context=ctx, parameter_overrides=[
        Parameter(k, value=v) for k, v in params.items()])
    return node, ctx


def close(node, ctx):
    node.destroy_node()
    rclpy.shutdown(context=ctx)


def published_after(node, seconds):
    before = node.published['joint_states']
    time.sleep(seconds)
    return node.published['joint_states'] - before


def test_the_plant_publishes_in_real_time_with_no_executor_spinning_the_node():
    """0.5 s of wall time without any executor: about 500 joint_states at 1 kHz. Bounds for a
    loaded machine: at least 100; at most 500 plus what a late start may catch up within
    max_stamp_lag (0.1 s: 100 periods), plus a margin of 20. The executor's timer would have
    published none (next test)."""
    node, ctx = alone()
    try:
        assert node.plant is not None and node.plant.alive
        assert 100 <= published_after(node, 0.5) <= 620
    finally:
        close(node, ctx)
    assert not node.plant.alive


def test_with_pacing_timer_the_executor_paces_the_plant(monkeypatch):
    monkeypatch.setenv(PACING_ENV, 'timer')
    node, ctx = alone()
    try:
        assert node.plant is None
        assert published_after(node, 0.3) == 0   # nobody spins the executor
    finally:
        close(node, ctx)


def test_a_failing_tick_stops_the_plant_and_ends_the_node_with_exit_code_1():
    """A bug in the plant (here a tick that raises) must not end its thread in silence: the
    node stops publishing and sets exit_code 1, which ends its spin."""
    node, ctx = alone()

    def broken():
        raise RuntimeError('a bug in the plant')

    try:
        node.sampler.next_period = broken
        deadline = time.monotonic() + 10
        while node.exit_code is None:
            assert time.monotonic() < deadline, 'the failure was not reported'
            time.sleep(0.01)
        assert node.exit_code == 1
        assert published_after(node, 0.2) == 0
    finally:
        close(node, ctx)


def test_the_plant_keeps_running_through_changes_of_the_factor(plant_factory):
    """0 (as fast as possible) -> 1 -> 0 -> 2 -> 1, each set while the plant runs: the tick
    that applies a change must not pace on the old factor (no failure, no exit code) and
    the plant integrates under each."""
    p = plant_factory(real_time_factor=0.0, publish_rate_hz=1000)
    for factor in (1.0, 0.0, 2.0, 1.0, 0.0):
        steps = p.sim.sim.steps
        assert p.set_params(real_time_factor=factor)[0].successful
        p.wait(lambda s=steps: p.sim.sim.steps > s + 200, f'steps at factor {factor}')
        assert p.sim.exit_code is None and not p.sim.fault


def test_an_unknown_pacing_is_refused_in_one_line_with_exit_code_2():
    env = dict(os.environ, **{PACING_ENV: 'fifo'})
    proc = subprocess.run([sys.executable, '-m', 'abb_ros.nodes.simulator'], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert f"{PACING_ENV}' = 'fifo' is invalid: valid range is thread or timer" in lines[0]


@pytest.mark.parametrize('rate_hz, every', [(50.0, 20), (1000.0, 1), (0.0, None)])
def test_joint_states_throttle_is_the_joint_states_opening_each_slot(plant_factory, rate_hz,
                                                                     every):
    """At 1 kHz: with 50 Hz every 20th joint_states message, byte for byte (stamps on the
    20 ms grid of simulated time); with 1000 Hz each; with 0 none."""
    p = plant_factory(real_time_factor=0.0, publish_rate_hz=1000, start_paused=True,
                      joint_states_throttle_hz=rate_hz)
    states = p.collect(JointState, 'joint_states')
    throttled = p.collect(JointState, 'joint_states_throttle')
    p.wait(lambda: p.node.count_publishers('joint_states_throttle') == 1, 'the publisher')
    p.spin_for(0.5)   # discovery both ways: the reliable subscriptions are matched
    p.pause(False)
    p.wait(lambda: len(states) >= 400, '400 joint_states')
    p.pause(True)
    p.drain(states)
    by_stamp = {stamp_ns(m): m for m in states}
    if every is None:
        assert throttled == []
        return
    assert len(throttled) >= 400 // every - 1
    stamps = [stamp_ns(m) for m in throttled]
    assert [b - a for a, b in zip(stamps, stamps[1:])] == [every * 1_000_000] * (len(stamps) - 1)
    assert all(s % (every * 1_000_000) == 0 for s in stamps)
    assert all(by_stamp[stamp_ns(m)] == m for m in throttled)


# ---- replies the middleware drops while it matches a new client --------------------------

class FakeSend:
    """A Service.send_response whose first ``drops`` calls rmw drops (rclpy's warning)."""

    def __init__(self, drops):
        self.drops = drops
        self.calls = 0

    def __call__(self, _response, _header):
        import warnings
        self.calls += 1
        if self.calls <= self.drops:
            warnings.warn('failed to send response (timeout): client will not receive '
                          'response', RuntimeWarning, stacklevel=1)


class Log:
    def __init__(self):
        self.lines = []

    def warning(self, line):
        self.lines.append(line)


def test_a_reply_the_middleware_drops_is_sent_again_until_it_goes(recwarn):
    from abb_ros.nodes.simulator.plant import resend_on_timeout
    send, log = FakeSend(drops=3), Log()
    resend_on_timeout(send, log, '/abb_simulator/set_parameters')(None, None)
    assert send.calls == 4 and log.lines == []
    assert not [w for w in recwarn if 'failed to send response' in str(w.message)]


def test_a_reply_dropped_every_time_is_given_up_with_one_line():
    from abb_ros.nodes.simulator.plant import RESPONSE_TRIES, resend_on_timeout
    send, log = FakeSend(drops=10 ** 6), Log()
    resend_on_timeout(send, log, '/abb_simulator/set_parameters')(None, None)
    assert send.calls == RESPONSE_TRIES
    assert len(log.lines) == 1 and log.lines[0].startswith('/abb_simulator/set_parameters')


def test_fresh_clients_at_factor_0_each_get_their_parameter_reply(plant_factory):
    """A client calling set_parameters as soon as it discovers the node, while the plant runs
    as fast as possible: every one is answered (a reply rmw dropped before the client was
    matched is sent again), and the plant runs on."""
    from rcl_interfaces.srv import SetParameters
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    p = plant_factory(real_time_factor=0.0)
    states = p.collect(JointState, 'joint_states')
    p.wait(lambda: len(states) > 100, 'joint_states')
    for i in range(10):
        node = Node(f'fresh_{i}', context=p.ctx)
        executor = SingleThreadedExecutor(context=p.ctx)
        executor.add_node(node)
        try:
            client = node.create_client(SetParameters, '/abb_simulator/set_parameters')
            deadline = time.monotonic() + test_simulator_node.DEADLINE_S
            while not client.service_is_ready():
                assert time.monotonic() < deadline, 'timed out after waiting for the service'
                executor.spin_once(timeout_sec=0.01)
            future = client.call_async(SetParameters.Request(parameters=[
                Parameter('max_stamp_lag', value=0.1 + i / 100).to_parameter_msg()]))
            executor.spin_until_future_complete(future, timeout_sec=test_simulator_node.DEADLINE_S)
            assert future.done(), f'timed out after {test_simulator_node.DEADLINE_S} s: no reply'
            assert future.result().results[0].successful
        finally:
            executor.shutdown()
            node.destroy_node()
    n = len(states)
    p.wait(lambda: len(states) > n + 100, 'joint_states after the calls')

"""Time under load: the simulator's stamps stay honest and /diagnostics says how late they are.

The node runs in process (test_simulator_node.Plant); a one-shot timer on the node itself
blocks its executor for a while, as a starved process would be. A stall shorter than
``max_stamp_lag`` is caught up (every period published, stamps unchanged) and reported as
``stamp_lag`` with WARN; a longer one is dropped (``slips``, ERROR) and the wall-time stamps
rejoin the wall clock.

The time rule (abb_ros/runtime/sim_clock.py, docs/time_under_load.md) over DDS, one transition
per test: a speed-up and back, a slow-down and back, pause, step, resume, reset. Each checks
what a consumer sees: on the wall clock, the stamps of ``joint_states`` are the wall time
while ``/clock`` is silent; on simulated time, ``/clock`` carries exactly the stamps.
"""

import asyncio
import json
import struct
import time

import pytest
import test_simulator_node
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from test_simulator_node import stamp_ns

pytestmark = pytest.mark.ros

PERIOD_NS = 1_000_000
plant_factory = test_simulator_node.plant_factory   # the fixture, shared


def stall_once(sim, seconds):
    """Block the node's executor once for ``seconds``, 0.3 s from now."""
    def block():
        timer.cancel()
        time.sleep(seconds)
    timer = sim.create_timer(0.3, block)


def statuses(p):
    """Every (level, message) of the simulation status from now on."""
    got = []
    p.node.create_subscription(
        DiagnosticArray, '/diagnostics',
        lambda m: got.extend((s.level, s.message) for s in m.status
                             if s.name.endswith('simulation')), 100)
    return got


def values_after(p, predicate, what):
    """The simulation status values once one satisfies ``predicate``."""
    p.wait(lambda: predicate(p.values()), what)
    return p.values()


def test_a_short_stall_is_caught_up_with_every_period_and_reported_as_stamp_lag(plant_factory):
    p = plant_factory(**{'max_stamp_lag': 5.0})
    got = p.collect(JointState, 'joint_states')
    levels = statuses(p)
    p.wait(lambda: len(got) > 100, 'joint_states')
    stall_once(p.sim, 0.4)
    v = values_after(p, lambda v: float(v.get('stamp_lag_max', 0)) >= 0.3, 'the lag reported')
    assert int(v['slips']) == 0 and int(v['overruns']) >= 300
    p.wait(lambda: len(got) > 1000, 'more joint_states')
    stamps = [stamp_ns(m) for m in got]
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
    assert set(gaps) == {PERIOD_NS}, 'a period was lost or repeated'
    # The window that held the stall reported it as WARN with the lag in the message.
    p.wait(lambda: any(level == DiagnosticStatus.WARN and 'ms late' in message
                       for level, message in levels), 'a WARN status giving the lag')
    assert not any(level == DiagnosticStatus.ERROR for level, _ in levels), levels


def test_a_stall_beyond_max_stamp_lag_is_dropped_counted_as_error_and_stamps_rejoin_the_wall(
        plant_factory):
    p = plant_factory(**{'max_stamp_lag': 0.1})
    got = p.collect(JointState, 'joint_states')
    levels = statuses(p)
    p.wait(lambda: len(got) > 100, 'joint_states')
    stall_once(p.sim, 0.6)
    # (A loaded machine may add slips of its own: the stall's shows in the time dropped.)
    v = values_after(p, lambda v: float(v.get('slipped_time', 0)) >= 0.4, 'the stall dropped')
    assert int(v['slips']) >= 1
    p.wait(lambda: any(level == DiagnosticStatus.ERROR and 'slip' in message
                       for level, message in levels), 'an ERROR status naming the slip')
    n = len(got)
    p.wait(lambda: len(got) > n + 200, 'joint_states after the stall')
    stamps = [stamp_ns(m) for m in got]
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
    assert min(gaps) == PERIOD_NS and max(gaps) >= 400 * PERIOD_NS   # one forward jump
    # After the jump the stamps follow the wall clock again: the node's current stamp comes
    # back within max_stamp_lag (+ one tick) of the wall clock. (Read between ticks; a loaded
    # machine can hold a tick back for a moment, so this waits for it rather than sampling once.
    # Without the re-anchoring the lag would stay near the stall's 0.5 s for ever.)
    p.wait(lambda: (time.time_ns() - p.sim.stamp_ns()) * 1e-9 < 0.1 + 0.05,
           'the stamps back within max_stamp_lag of the wall clock')
    assert float(v['stamp_lag_max']) <= 0.1 + 0.01


@pytest.mark.slow
def test_diagnostics_give_the_real_time_factor_over_the_window_and_since_start(plant_factory):
    p = plant_factory()
    v = values_after(p, lambda v: float(v.get('real_time_factor_since_start', 0)) > 0,
                     'real_time_factor_since_start')
    assert 0.5 < float(v['real_time_factor']) < 1.5
    assert 0.5 < float(v['real_time_factor_since_start']) < 1.5
    assert float(v['target_real_time_factor']) == 1.0
    assert 'stamp_lag' in v and 'stamp_lag_max' in v and float(v['max_stamp_lag']) == 0.1
    p.pause(True)
    p.spin_for(2.5)
    v = p.values()
    # Paused time is not counted: since start stays near 1 although no step was made.
    assert 0.5 < float(v['real_time_factor_since_start']) < 1.5


# ---- the time rule, transition by transition ---------------------------------------------------

WALL_SLACK_S = 0.1 + 0.05
"""How far a stamp on the wall clock may be from it when read: max_stamp_lag and one tick."""


def on_the_wall(p):
    """Whether the node's current stamp is within WALL_SLACK_S of the wall clock."""
    return abs(time.time_ns() - p.sim.stamp_ns()) * 1e-9 < WALL_SLACK_S


def stamps(messages):
    return [stamp_ns(m) for m in messages]


def assert_clock_carries_the_stamps(states, clocks):
    """Over the span both saw, /clock holds exactly the joint_states stamps, and both only
    go forward."""
    s, c = stamps(states), stamps(clocks)
    assert all(b > a for a, b in zip(s, s[1:])), 'a joint_states stamp went back or repeated'
    assert all(b > a for a, b in zip(c, c[1:])), 'a /clock stamp went back or repeated'
    lo, hi = max(s[0], c[0]), min(s[-1], c[-1])
    assert hi - lo > 100 * PERIOD_NS, 'too short an overlap to compare'
    assert {t for t in s if lo <= t <= hi} == {t for t in c if lo <= t <= hi}


def says_time_base(p, expected):
    """Wait for /diagnostics to say ``expected`` as the time base."""
    p.wait(lambda: p.values().get('time_base') == expected, f'time_base {expected!r}')


def factor(p, value):
    assert p.set_params(real_time_factor=value)[0].successful


def test_at_factor_1_stamps_are_the_wall_clock_and_clock_is_silent(plant_factory):
    p = plant_factory()
    states, clocks = p.collect(JointState, 'joint_states'), p.collect(Clock, '/clock')
    p.wait(lambda: len(states) > 300, 'joint_states')
    p.wait(lambda: on_the_wall(p), 'the stamps on the wall clock')
    says_time_base(p, 'wall clock, no /clock')
    assert not clocks


def test_after_a_speed_up_and_back_to_1_clock_goes_on_carrying_the_stamps(plant_factory):
    p = plant_factory()
    states, clocks = p.collect(JointState, 'joint_states'), p.collect(Clock, '/clock')
    p.wait(lambda: len(states) > 100, 'joint_states')
    assert not clocks
    factor(p, 2.0)
    p.wait(lambda: len(clocks) > 100, '/clock once simulated time runs ahead')
    p.spin_for(1.0)
    factor(p, 1.0)
    ahead_s = (p.sim.stamp_ns() - time.time_ns()) * 1e-9
    slipped_ns = p.sim.pacer.slipped_ns
    assert ahead_s > 0.3                         # ~1 s at factor 2 put the stamps ahead
    n = len(clocks)
    p.spin_for(1.5)                              # back at factor 1: /clock does not go silent
    p.wait(lambda: len(clocks) > n + 500, '/clock at factor 1 after the speed-up')
    assert_clock_carries_the_stamps(states, clocks)
    s = stamps(states)
    assert all(b - a == PERIOD_NS for a, b in zip(s, s[1:]) if a >= stamp_ns(clocks[0]))
    # Still ahead (never pulled back) by what the speed-up gained, less what slips dropped
    # (a starved test process makes some: counted, and stamps stay one period apart) and
    # less the lag of the moment (max_stamp_lag, 0.1 s, unless the plant thread is starved).
    slipped_s = (p.sim.pacer.slipped_ns - slipped_ns) * 1e-9
    ahead_now = (p.sim.stamp_ns() - time.time_ns()) * 1e-9
    assert ahead_now + slipped_s == pytest.approx(ahead_s, abs=0.3)
    says_time_base(p, 'simulated, on /clock')


def test_after_a_slow_down_and_back_to_1_stamps_rejoin_the_wall_clock_on_clock(plant_factory):
    p = plant_factory()
    states, clocks = p.collect(JointState, 'joint_states'), p.collect(Clock, '/clock')
    p.wait(lambda: len(states) > 100, 'joint_states')
    factor(p, 0.5)
    p.wait(lambda: len(clocks) > 100, '/clock once simulated time falls behind')
    p.spin_for(1.0)
    assert (time.time_ns() - p.sim.stamp_ns()) * 1e-9 > 0.3
    factor(p, 1.0)
    p.wait(lambda: on_the_wall(p), 'the stamps back on the wall clock')
    n = len(clocks)
    p.wait(lambda: len(clocks) > n + 300, '/clock at factor 1 after the slow-down')
    assert_clock_carries_the_stamps(states, clocks)
    s = stamps(states)
    assert max(b - a for a, b in zip(s, s[1:])) > 300 * PERIOD_NS   # the jump forward


def test_pause_step_and_resume_keep_clock_equal_to_the_stamps(plant_factory):
    p = plant_factory()
    states, clocks = p.collect(JointState, 'joint_states'), p.collect(Clock, '/clock')
    p.wait(lambda: len(states) > 100, 'joint_states')
    assert not clocks
    p.pause(True)
    p.drain(states)
    held = stamp_ns(states[-1])
    p.wait(lambda: clocks, '/clock once paused')
    assert stamps(clocks) == [held]              # /clock starts at the held time
    for k in range(1, 4):
        assert p.step().success
        p.wait(lambda: stamp_ns(states[-1]) == held + k * PERIOD_NS, f'step {k}')
        p.wait(lambda: stamp_ns(clocks[-1]) == held + k * PERIOD_NS, f'/clock of step {k}')
    p.pause(False)
    p.wait(lambda: on_the_wall(p), 'the stamps back on the wall clock after the resume')
    n = len(clocks)
    p.wait(lambda: len(clocks) > n + 300, '/clock after the resume')
    assert_clock_carries_the_stamps(states, clocks)
    says_time_base(p, 'wall clock, on /clock')


def test_a_reset_at_factor_1_keeps_the_wall_clock_and_clock_silent(plant_factory):
    p = plant_factory()
    states, clocks = p.collect(JointState, 'joint_states'), p.collect(Clock, '/clock')
    p.wait(lambda: len(states) > 100, 'joint_states')
    assert p.call(Trigger, '/abb_simulator/reset', Trigger.Request()).success
    n = len(states)
    p.wait(lambda: len(states) > n + 300, 'joint_states after the reset')
    p.wait(lambda: on_the_wall(p), 'the stamps on the wall clock after the reset')
    s = stamps(states)
    assert all(b > a for a, b in zip(s, s[1:])), [(a, b) for a, b in zip(s, s[1:]) if b <= a][:5]
    assert not clocks


def test_started_paused_steps_and_a_reset_go_on_clock_from_the_wall_time_of_start_up(
        plant_factory):
    p = plant_factory(start_paused=True)
    states, clocks = p.collect(JointState, 'joint_states'), p.collect(Clock, '/clock')
    assert p.step().success
    p.wait(lambda: states and clocks, 'the step on joint_states and /clock')
    first = stamp_ns(states[-1])
    assert stamps(clocks) == [first]
    assert abs(time.time_ns() - first) * 1e-9 < 30.0    # the wall clock at start-up
    assert p.call(Trigger, '/abb_simulator/reset', Trigger.Request()).success
    assert p.step().success
    p.wait(lambda: len(states) == 2 and len(clocks) == 2, 'the step after the reset')
    assert stamps(states) == stamps(clocks) == [first, first + PERIOD_NS]   # never back


def test_the_live_view_advertises_clock_only_once_it_carries_it(plant_factory):
    """At factor 1 the viewer sees no /clock channel; after a speed-up it is advertised and
    its messages are the node's /clock (read with tornado's generic WebSocket client)."""
    from rclpy.serialization import deserialize_message
    from tornado.ioloop import IOLoop
    from tornado.websocket import websocket_connect

    p = plant_factory(**{'live_view.enabled': True, 'live_view.port': 0})
    url = p.sim.live.view.url

    channels = {}

    async def read_until(ws, done, seconds=20.0):
        """Read frames (advertisements into ``channels``) until ``done(frame)``, or until
        ``seconds`` passed (then None)."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                frame = await asyncio.wait_for(ws.read_message(), end - time.monotonic())
            except asyncio.TimeoutError:
                return None
            if isinstance(frame, str) and json.loads(frame)['op'] == 'advertise':
                channels.update({c['topic']: c for c in json.loads(frame)['channels']})
            if done(frame):
                return frame
        return None

    async def session():
        ws = await websocket_connect(url, subprotocols=['foxglove.sdk.v1'])
        info = json.loads(await ws.read_message())
        await read_until(ws, lambda _: '/joint_states' in channels)
        await read_until(ws, lambda _: False, seconds=1.0)   # a second more at factor 1
        at_factor_1 = set(channels)
        await IOLoop.current().run_in_executor(None, factor, p, 2.0)
        await read_until(ws, lambda _: '/clock' in channels)
        await ws.write_message(json.dumps({'op': 'subscribe', 'subscriptions': [
            {'id': 3, 'channelId': channels['/clock']['id']}]}))
        frame = await read_until(ws, lambda f: isinstance(f, bytes) and f[0] == 1)
        ws.close()
        return info, at_factor_1, frame

    info, at_factor_1, frame = IOLoop().run_sync(session, timeout=30)
    assert 'time' not in info['capabilities']
    assert '/joint_states' in at_factor_1 and '/clock' not in at_factor_1
    assert channels['/clock']['schemaName'] == 'rosgraph_msgs/msg/Clock'
    subscription, log_time = struct.unpack_from('<IQ', frame, 1)
    clock = deserialize_message(frame[13:], Clock)
    assert subscription == 3 and stamp_ns(clock) == log_time


# ---- factors the clock cannot represent, and waking the plant for a new one ---------------

def test_factors_the_pacing_clock_cannot_wait_for_are_refused_naming_the_range(plant_factory):
    p = plant_factory()
    states = p.collect(JointState, 'joint_states')
    p.wait(lambda: len(states) > 100, 'joint_states')
    for value in (1e-14, 5e-324, 9.9e-7):
        (result,) = p.set_params(real_time_factor=value)
        assert not result.successful
        assert result.reason.startswith("parameter 'real_time_factor'"), result.reason
        assert '0 (as fast as possible) or [1e-06, 1000]' in result.reason
    assert p.sim.get_parameter('real_time_factor').value == 1.0
    n = len(states)
    p.wait(lambda: len(states) > n + 300, 'joint_states after the refused factors')
    assert p.sim.plant.alive and p.sim.exit_code is None


def test_a_new_factor_wakes_a_plant_asleep_for_a_tiny_one(plant_factory):
    p = plant_factory()
    states = p.collect(JointState, 'joint_states')
    p.wait(lambda: len(states) > 100, 'joint_states')
    factor(p, 1e-6)          # the next period is 1000 s of wall time away
    p.spin_for(0.5)
    n = len(states)
    t0 = time.monotonic()
    factor(p, 1.0)
    p.wait(lambda: len(states) > n + 200, 'joint_states at factor 1 again', timeout=5.0)
    assert time.monotonic() - t0 < 5.0
    p.wait(lambda: float(p.values().get('target_real_time_factor', 'nan')) == 1.0,
           'the new target on /diagnostics')

"""Hostile requests to the simulator's simulation_interfaces services never kill or freeze it.

Over real DDS, as test_simulation_interfaces_node.py: the simulator node in process, a client
node calling it with the standard's generated types. Claims: each bad request gets one reply
whose message names the field and what is valid; nothing is logged as a traceback; the node
answers the next request and keeps publishing joint_states.
"""

import copy
import signal
import subprocess
import sys
import time

import pytest
import rclpy
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger
from test_simulator_node import DEADLINE_S, ROOT, Plant

srv = pytest.importorskip('simulation_interfaces.srv', reason='simulation_interfaces is not '
                          'built (needs cmake and a C/C++ compiler)')
from simulation_interfaces.action import SimulateSteps  # noqa: E402
from simulation_interfaces.msg import EntityFilters, Result, SimulationState  # noqa: E402

from abb_ros.nodes.simulator.simulation_interfaces import (  # noqa: E402
    MAX_CALL_STEPS,
    MAX_FILTER_CHARS,
    MAX_GOAL_STEPS,
)

pytestmark = pytest.mark.ros

SIM = '/abb_simulator'
OK = Result.RESULT_OK
ANSWER_S = 2.0
"""Longest wall time a hostile request may take to be answered (a shared, loaded machine)."""


@pytest.fixture
def playing():
    """A simulator playing at real time, 100 Hz: joint_states flows while requests come."""
    p = Plant(real_time_factor=1.0, publish_rate_hz=100)
    yield p
    p.close()


@pytest.fixture
def paused():
    """A paused simulator, as fast as possible between steps, 1 kHz."""
    p = Plant(start_paused=True, real_time_factor=0.0, publish_rate_hz=1000)
    yield p
    p.close()


def call(plant, kind, name, **fields):
    return plant.call(kind, f'{SIM}/{name}', kind.Request(**fields))


def entities(plant, pattern):
    return call(plant, srv.GetEntities, 'get_entities', filters=EntityFilters(filter=pattern))


def assert_still_publishing(plant, states):
    before = len(states)
    plant.wait(lambda: len(states) >= before + 5, 'joint_states after the hostile requests')


HOSTILE_FILTERS = [
    'a{1001}',                              # beyond RE2's repetition limit
    '(' * 120 + 'a' + ')' * 120 + '{2,}' * 4,
    '(?aL)ball',                            # Python re: incompatible flags, ValueError
    '(ball)\\1',                            # a backreference: not a regular language
    '(?=ball)',                             # lookahead
    '[[:nonsense:]]',
    '[',
    'x' * (MAX_FILTER_CHARS + 1),
    '(' * 5000 + ')' * 5000,                # Python re: RecursionError
]


def test_hostile_filters_are_refused_with_the_field_and_what_is_valid(playing, capfd):
    states = playing.collect(JointState, 'joint_states')
    for pattern in HOSTILE_FILTERS:
        t0 = time.monotonic()
        reply = entities(playing, pattern)
        assert time.monotonic() - t0 < ANSWER_S, pattern[:40]
        assert reply.result.result == Result.RESULT_OPERATION_FAILED, pattern[:40]
        message = reply.result.error_message
        assert message.startswith('filters.filter') and 'valid:' in message, message
        assert f'at most {MAX_FILTER_CHARS} characters' in message
        assert '\n' not in message and reply.entities == []
    assert_still_publishing(playing, states)
    assert entities(playing, '^ball_').entities == ['ball_1', 'ball_2']
    err = capfd.readouterr().err
    assert 'Traceback' not in err and 'Error parsing' not in err


def test_catastrophic_backtracking_patterns_answer_at_once(playing):
    states = playing.collect(JointState, 'joint_states')
    for pattern in ('(.*)*' * 20 + 'X', '^(a|a?)+$', '(([a-z_0-9]*)*)*$!', '(x+x+)+y',
                    'ball_{99999999999999999999}'):   # Python re: OverflowError; RE2: literal
        t0 = time.monotonic()
        reply = entities(playing, pattern)
        assert time.monotonic() - t0 < ANSWER_S, pattern
        assert reply.result.result == OK and reply.entities == [], pattern
    assert_still_publishing(playing, states)


def test_posix_classes_match_as_posix_extended_regular_expressions_define_them(playing):
    assert entities(playing, '^[[:alpha:]]+$').entities == ['deck', 'rotor']
    assert entities(playing, '^ball_[[:digit:]]+$').entities == ['ball_1', 'ball_2']
    assert entities(playing, '[[:upper:]]').entities == []
    assert entities(playing, '').entities == ['deck', 'rotor', 'ball_1', 'ball_2']
    assert entities(playing, 'deck|rotor').entities == ['deck', 'rotor']


# ---- stepping ---------------------------------------------------------------------------------

def step(plant, steps):
    return call(plant, srv.StepSimulation, 'step_simulation', steps=steps).result


def state_of(plant):
    return call(plant, srv.GetSimulationState, 'get_simulation_state').state.state


def test_step_simulation_beyond_its_stated_maximum_is_refused_at_once(paused, capfd):
    states = paused.collect(JointState, 'joint_states')
    for steps in (2 ** 63 - 1, 2 ** 64 - 1, MAX_CALL_STEPS + 1):
        t0 = time.monotonic()
        refused = step(paused, steps)
        assert time.monotonic() - t0 < ANSWER_S
        assert refused.result == Result.RESULT_OPERATION_FAILED
        assert refused.error_message.startswith(f'steps {steps}: at most {MAX_CALL_STEPS}')
        assert 'SimulateSteps' in refused.error_message
    assert states == []                      # nothing was stepped
    assert step(paused, MAX_CALL_STEPS).result == OK
    paused.wait(lambda: len(states) == MAX_CALL_STEPS, 'the steps of the largest call')
    assert 'Traceback' not in capfd.readouterr().err


def _goal(plant, steps):
    client = ActionClient(plant.node, SimulateSteps, f'{SIM}/simulate_steps')
    plant.wait(client.server_is_ready, 'the SimulateSteps server')
    future = client.send_goal_async(SimulateSteps.Goal(steps=steps))
    plant.wait(future.done, 'goal acceptance')
    return future.result()


def test_a_goal_beyond_its_stated_maximum_is_aborted_with_the_maximum(paused):
    for steps in (2 ** 63 - 1, MAX_GOAL_STEPS + 1):
        handle = _goal(paused, steps)
        result = handle.get_result_async()
        paused.wait(result.done, 'the aborted result')
        outcome = result.result().result.result
        assert outcome.result == Result.RESULT_OPERATION_FAILED
        assert outcome.error_message.startswith(f'steps {steps}: at most {MAX_GOAL_STEPS}')
    assert step(paused, 1).result == OK


def test_a_long_goal_leaves_the_node_serving_and_owning_the_stepping(paused):
    states = paused.collect(JointState, 'joint_states')
    handle = _goal(paused, MAX_GOAL_STEPS)
    paused.wait(lambda: len(states) > 100, 'the goal stepping')
    t0 = time.monotonic()
    assert state_of(paused) == SimulationState.STATE_PAUSED
    assert time.monotonic() - t0 < ANSWER_S
    # Nothing else may step, play, stop or reset while the goal owns the stepping.
    owner = 'a SimulateSteps goal owns the stepping'
    R = Result
    for state in (SimulationState.STATE_PLAYING, SimulationState.STATE_STOPPED):
        refused = call(paused, srv.SetSimulationState, 'set_simulation_state',
                       state=SimulationState(state=state)).result
        assert refused.result == R.RESULT_INCORRECT_STATE and owner in refused.error_message
    assert step(paused, 1).result == R.RESULT_INCORRECT_STATE
    reset = call(paused, srv.ResetSimulation, 'reset_simulation').result
    assert reset.result == R.RESULT_INCORRECT_STATE and owner in reset.error_message
    for reply in (paused.step(),
                  paused.call(Trigger, f'{SIM}/reset', Trigger.Request()),
                  paused.call(SetBool, f'{SIM}/pause', SetBool.Request(data=False))):
        assert not reply.success and owner in reply.message
    assert state_of(paused) == SimulationState.STATE_PAUSED
    cancel = handle.cancel_goal_async()
    paused.wait(cancel.done, 'the cancel reply')
    result = handle.get_result_async()
    paused.wait(result.done, 'the cancelled result')
    assert result.result().status == 5   # GoalStatus.STATUS_CANCELED
    # The goal gone, the stepping is free again.
    assert paused.step().success
    assert call(paused, srv.SetSimulationState, 'set_simulation_state',
                state=SimulationState(state=SimulationState.STATE_PLAYING)).result.result == OK



# ---- SetEntityState -----------------------------------------------------------------------

def _states(plant):
    reply = call(plant, srv.GetEntitiesStates, 'get_entities_states')
    return dict(zip(reply.entities, reply.states))


def _set(plant, entity, state):
    return call(plant, srv.SetEntityState, 'set_entity_state', entity=entity,
                state=state).result


def _refused(plant, entity, state, *needles):
    result = _set(plant, entity, state)
    assert result.result == srv.SetEntityState.Response.INVALID_POSE, result.error_message
    message = result.error_message
    assert message.startswith(entity) and 'valid' in message and '\n' not in message, message
    for needle in needles:
        assert needle in message, message


def test_set_entity_state_refuses_what_the_next_step_would_reject(paused, recwarn, capfd):
    states = paused.collect(JointState, 'joint_states')
    now = _states(paused)
    ball = copy.deepcopy(now['ball_1'])
    ball.pose.orientation.x = ball.pose.orientation.y = 0.0
    ball.pose.orientation.z = ball.pose.orientation.w = 0.0
    _refused(paused, 'ball_1', ball, 'state.pose.orientation', 'unit quaternion')
    fast = copy.deepcopy(now['ball_1'])       # along the race, 300 times the rotor's speed
    v = fast.twist.linear
    v.x, v.y, v.z = v.x * 300, v.y * 300, v.z * 300
    _refused(paused, 'ball_1', fast, "phi'", '100000')
    huge = copy.deepcopy(now['ball_1'])
    huge.twist.linear.x = 1e308
    _refused(paused, 'ball_1', huge, 'state.twist.linear.x')
    deck = copy.deepcopy(now['deck'])
    deck.pose.position.x = 0.5
    _refused(paused, 'deck', deck, 'state.pose.position.x', '0.02')
    deck = copy.deepcopy(now['deck'])
    deck.pose.orientation.w = 0.0
    _refused(paused, 'deck', deck, 'state.pose.orientation')
    deck = copy.deepcopy(now['deck'])
    deck.twist.angular.x = 1e200
    _refused(paused, 'deck', deck, 'state.twist.angular.x', '1000')
    deck = copy.deepcopy(now['deck'])
    deck.twist.linear.x = 900.0               # within the shock's range; gone in one step
    _refused(paused, 'deck', deck, 'next step', 'envelope')
    assert _states(paused) == now             # nothing was set
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]
    assert step(paused, 5).result == OK
    paused.wait(lambda: len(states) >= 5, 'joint_states after the refusals')
    assert 'Traceback' not in capfd.readouterr().err


@pytest.mark.slow
def test_sigint_during_a_long_goal_ends_the_node_at_once_with_exit_0():
    proc = subprocess.Popen(
        [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args', '-r', '__ns:=/longgoal',
         '-p', 'real_time_factor:=0.0', '-p', 'start_paused:=true'],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node('goal_sender', context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    feedback = []
    try:
        client = ActionClient(node, SimulateSteps, '/longgoal/abb_simulator/simulate_steps')
        deadline = time.monotonic() + DEADLINE_S
        while not client.server_is_ready():
            assert time.monotonic() < deadline, 'timed out after waiting for the node'
            executor.spin_once(timeout_sec=0.1)
        future = client.send_goal_async(SimulateSteps.Goal(steps=MAX_GOAL_STEPS),
                                        feedback_callback=feedback.append)
        while not feedback:
            assert time.monotonic() < deadline, 'timed out after waiting for feedback'
            executor.spin_once(timeout_sec=0.1)
        assert future.result().accepted
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=5) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=ctx)
    assert 'Traceback' not in proc.communicate()[0]

"""The simulator serves the ROS 2 simulation_interfaces standard over real DDS.

Each test runs the simulator node in process (its own Context, its executor in a thread,
test_simulator_node.Plant) and calls it with the generated types from a client node, as a
harness built against the standard's package would. Claims: what GetSimulatorFeatures lists
is exactly what is served; the state machine's transitions and refusals; a step is exactly one
publish period of stamps and its messages; SimulateSteps reports progress, is cancelled within
a batch and ends paused; the reset scopes; entity states agree with deck/pose and
joint_states; SetEntityState moves a ball or the deck and refuses the rest with a reason.
"""

import math
import subprocess
import sys
import time

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from test_simulator_node import DEADLINE_S, ROOT, Plant, stamp_ns

srv = pytest.importorskip('simulation_interfaces.srv', reason='simulation_interfaces is not '
                          'built (needs cmake and a C/C++ compiler)')
from simulation_interfaces.action import SimulateSteps  # noqa: E402
from simulation_interfaces.msg import (  # noqa: E402
    Bounds,
    EntityFilters,
    EntityState,
    Result,
    SimulationState,
    SimulatorFeatures,
)

pytestmark = pytest.mark.ros

SIM = '/abb_simulator'
PERIOD_NS = 1_000_000   # publish_rate_hz 1000
OK = Result.RESULT_OK


@pytest.fixture
def plant():
    p = Plant(start_paused=True, real_time_factor=0.0, publish_rate_hz=1000)
    yield p
    p.close()


def call(plant, kind, name, **fields):
    return plant.call(kind, f'{SIM}/{name}', kind.Request(**fields))


def state_of(plant) -> int:
    reply = call(plant, srv.GetSimulationState, 'get_simulation_state')
    assert reply.result.result == OK
    return reply.state.state


def set_state(plant, state):
    return call(plant, srv.SetSimulationState, 'set_simulation_state',
                state=SimulationState(state=state)).result


def step(plant, steps):
    return call(plant, srv.StepSimulation, 'step_simulation', steps=steps).result


def first_step(plant, states):
    """Step once and wait for its message (the start sample went out before we subscribed)."""
    assert step(plant, 1).result == OK
    plant.wait(lambda: states, 'the first step')
    return states[-1]


def test_the_features_listed_are_exactly_the_interfaces_served(plant):
    reply = call(plant, srv.GetSimulatorFeatures, 'get_simulator_features')
    features = set(reply.features.features)
    F = SimulatorFeatures
    assert features == {F.SIMULATION_STATE_GETTING, F.SIMULATION_STATE_SETTING,
                        F.SIMULATION_STATE_PAUSE, F.STEP_SIMULATION_SINGLE,
                        F.STEP_SIMULATION_MULTIPLE, F.STEP_SIMULATION_ACTION,
                        F.SIMULATION_RESET, F.SIMULATION_RESET_TIME,
                        F.SIMULATION_RESET_STATE, F.ENTITY_STATE_GETTING,
                        F.ENTITY_STATE_SETTING}
    names = {name for name, _ in plant.node.get_service_names_and_types()}
    for service in ('get_simulation_state', 'set_simulation_state', 'step_simulation',
                    'reset_simulation', 'get_entities', 'get_entity_state',
                    'get_entities_states', 'set_entity_state'):
        assert f'{SIM}/{service}' in names
    for unserved in ('spawn_entity', 'delete_entity', 'get_named_poses', 'load_world'):
        assert f'{SIM}/{unserved}' not in names


def test_state_transitions_follow_the_standard_and_pause_is_the_same_state(plant):
    S = SimulationState
    R = srv.SetSimulationState.Response
    assert state_of(plant) == S.STATE_PAUSED    # start_paused
    assert set_state(plant, S.STATE_PAUSED).result == R.ALREADY_IN_TARGET_STATE
    assert set_state(plant, S.STATE_PLAYING).result == OK
    assert state_of(plant) == S.STATE_PLAYING
    plant.pause(True)                           # ~/pause is the same state machine
    assert state_of(plant) == S.STATE_PAUSED
    assert set_state(plant, S.STATE_STOPPED).result == OK
    assert state_of(plant) == S.STATE_STOPPED
    refused = set_state(plant, S.STATE_PAUSED)
    assert refused.result == R.INCORRECT_TRANSITION and 'STOPPED' in refused.error_message
    assert set_state(plant, S.STATE_NO_WORLD).result == R.INCORRECT_TRANSITION
    assert set_state(plant, 77).result == R.INCORRECT_TRANSITION
    assert set_state(plant, S.STATE_PLAYING).result == OK
    plant.pause(False)
    assert state_of(plant) == S.STATE_PLAYING


def test_k_steps_advance_the_stamps_by_exactly_k_periods_and_publish_each(plant):
    states = plant.collect(JointState, 'joint_states')
    clocks = plant.collect(Clock, '/clock')
    t0 = stamp_ns(first_step(plant, states))
    for k in (1, 7, 250):
        before = len(states)
        assert step(plant, k).result == OK
        plant.wait(lambda: len(states) == before + k, f'{k} steps')
        stamps = [stamp_ns(m) for m in states[before:]]
        assert stamps == [t0 + PERIOD_NS * (i + 1) for i in range(k)]
        t0 = stamps[-1]
    plant.wait(lambda: clocks and stamp_ns(clocks[-1]) == t0, '/clock at the last step')
    assert state_of(plant) == SimulationState.STATE_PAUSED


def test_stepping_is_refused_while_playing(plant):
    assert set_state(plant, SimulationState.STATE_PLAYING).result == OK
    refused = step(plant, 1)
    assert refused.result == Result.RESULT_INCORRECT_STATE
    assert 'pause' in refused.error_message


def _action_client(plant):
    client = ActionClient(plant.node, SimulateSteps, f'{SIM}/simulate_steps')
    plant.wait(client.server_is_ready, 'the SimulateSteps server')
    return client


def _send(plant, client, steps, feedback):
    future = client.send_goal_async(SimulateSteps.Goal(steps=steps),
                                    feedback_callback=lambda m: feedback.append(m.feedback))
    plant.wait(future.done, 'goal acceptance')
    handle = future.result()
    assert handle.accepted
    return handle


def test_simulate_steps_reports_progress_and_ends_paused_after_exactly_the_steps(plant):
    states = plant.collect(JointState, 'joint_states')
    t0 = stamp_ns(first_step(plant, states))
    client = _action_client(plant)
    feedback = []
    steps = 3000
    handle = _send(plant, client, steps, feedback)
    result = handle.get_result_async()
    plant.wait(result.done, 'the SimulateSteps result', timeout=60)
    assert result.result().result.result.result == OK
    assert feedback, 'no feedback'
    assert all(f.completed_steps + f.remaining_steps == steps for f in feedback)
    done = [f.completed_steps for f in feedback]
    assert done == sorted(done) and done[-1] == steps
    plant.wait(lambda: stamp_ns(states[-1]) == t0 + steps * PERIOD_NS, 'the last period')
    assert state_of(plant) == SimulationState.STATE_PAUSED


def test_a_cancelled_goal_stops_within_a_batch_and_says_how_far_it_got(plant):
    states = plant.collect(JointState, 'joint_states')
    t0 = stamp_ns(first_step(plant, states))
    client = _action_client(plant)
    feedback = []
    handle = _send(plant, client, 10_000_000, feedback)
    plant.wait(lambda: feedback, 'the first feedback')
    cancel = handle.cancel_goal_async()
    plant.wait(cancel.done, 'the cancel reply')
    result = handle.get_result_async()
    plant.wait(result.done, 'the cancelled result')
    message = result.result().result.result.error_message
    assert result.result().status == 5   # GoalStatus.STATUS_CANCELED
    done = int(message.split('after ')[1].split(' of')[0])
    assert 0 < done < 10_000_000
    plant.drain(states)
    assert stamp_ns(states[-1]) == t0 + done * PERIOD_NS
    assert step(plant, 1).result == OK    # paused, ready for the next goal


def test_simulate_steps_while_playing_is_aborted_with_incorrect_state(plant):
    assert set_state(plant, SimulationState.STATE_PLAYING).result == OK
    client = _action_client(plant)
    handle = _send(plant, client, 10, [])
    result = handle.get_result_async()
    plant.wait(result.done, 'the aborted result')
    assert result.result().result.result.result == Result.RESULT_INCORRECT_STATE


def _reset(plant, scope):
    return call(plant, srv.ResetSimulation, 'reset_simulation', scope=scope).result


def test_reset_scopes_rewind_time_and_or_state_as_the_standard_defines(plant):
    R = srv.ResetSimulation.Request
    states = plant.collect(JointState, 'joint_states')
    clocks = plant.collect(Clock, '/clock')
    assert _reset(plant, R.SCOPE_ALL).result == OK      # the start sample, subscribed now
    plant.wait(lambda: states, 'the start sample')
    start = states[-1]
    assert stamp_ns(start) == 0
    assert step(plant, 100).result == OK
    plant.wait(lambda: len(states) == 101, '100 steps')
    moved = states[-1]
    # SCOPE_STATE: the initial state, time goes on (the next period carries it).
    assert _reset(plant, R.SCOPE_STATE).result == OK
    assert step(plant, 1).result == OK
    plant.wait(lambda: len(states) == 102, 'a step after the state reset')
    assert stamp_ns(states[-1]) == stamp_ns(moved) + PERIOD_NS
    # SCOPE_TIME: stamps and /clock back to 0 at once, the state untouched.
    assert step(plant, 20).result == OK
    plant.wait(lambda: len(states) == 122, '20 steps')
    before = states[-1]
    assert _reset(plant, R.SCOPE_TIME).result == OK
    plant.wait(lambda: len(states) == 123, 'the start sample after the time reset')
    assert stamp_ns(states[-1]) == 0 and list(states[-1].position) == list(before.position)
    plant.wait(lambda: stamp_ns(clocks[-1]) == 0, '/clock back to 0')
    # SCOPE_DEFAULT (= ALL): as at start-up, sample for sample.
    assert step(plant, 30).result == OK
    plant.wait(lambda: len(states) == 153, '30 steps')
    assert _reset(plant, R.SCOPE_DEFAULT).result == OK
    plant.wait(lambda: len(states) == 154, 'the start sample after the full reset')
    assert states[-1] == start
    refused = _reset(plant, R.SCOPE_SPAWNED)
    assert refused.result == Result.RESULT_FEATURE_UNSUPPORTED
    assert _reset(plant, R.SCOPE_ALL).result == OK


def test_stopped_is_paused_at_the_start_and_plays_from_there(plant):
    states = plant.collect(JointState, 'joint_states')
    assert _reset(plant, srv.ResetSimulation.Request.SCOPE_ALL).result == OK
    plant.wait(lambda: states, 'the start sample')
    start = states[-1]
    assert step(plant, 50).result == OK
    assert set_state(plant, SimulationState.STATE_STOPPED).result == OK
    plant.wait(lambda: len(states) == 52 and states[-1] == start,
               'the start sample after STOPPED')
    assert step(plant, 1).result == OK       # a stopped simulation steps, and is paused
    assert state_of(plant) == SimulationState.STATE_PAUSED


def _entity_states(plant):
    reply = call(plant, srv.GetEntitiesStates, 'get_entities_states')
    assert reply.result.result == OK
    return dict(zip(reply.entities, reply.states))


def test_entity_states_agree_with_deck_pose_and_joint_states(plant):
    poses = plant.collect(PoseStamped, 'deck/pose')
    states = plant.collect(JointState, 'joint_states')
    assert step(plant, 40).result == OK
    plant.wait(lambda: len(poses) >= 40 and len(states) >= 40, '40 steps')
    entities = _entity_states(plant)
    n = len(states[-1].name) - 1
    assert list(entities) == ['deck', 'rotor'] + [f'ball_{i + 1}' for i in range(n)]
    deck = entities['deck']
    assert deck.header.frame_id == 'base'
    assert stamp_ns(deck) == stamp_ns(poses[-1]) == stamp_ns(states[-1])
    assert deck.pose == poses[-1].pose
    theta, omega = states[-1].position[0], states[-1].velocity[0]
    rotor = entities['rotor']
    # The rotor spins about the deck's z axis: its angular velocity along that axis is the
    # deck's plus omega (the deck's own rates are tiny next to omega).
    w = rotor.twist.angular
    assert math.isclose(math.hypot(w.x, w.y, w.z), omega, rel_tol=1e-3)
    yaw = 2 * math.atan2(rotor.pose.orientation.z, rotor.pose.orientation.w)
    assert math.isclose(math.remainder(yaw - theta, 2 * math.pi), 0.0, abs_tol=1e-3)
    c = np.array([deck.pose.position.x, deck.pose.position.y, deck.pose.position.z])
    for i in range(n):
        ball = entities[f'ball_{i + 1}'].pose.position
        offset = np.array([ball.x, ball.y, ball.z]) - c
        psi = theta + states[-1].position[i + 1]
        assert math.isclose(math.atan2(offset[1], offset[0]),
                            math.remainder(psi, 2 * math.pi), abs_tol=1e-3)
    one = call(plant, srv.GetEntityState, 'get_entity_state', entity='ball_1')
    assert one.result.result == OK and one.state == entities['ball_1']


def test_unknown_entities_and_unsupported_filters_are_refused(plant):
    missing = call(plant, srv.GetEntityState, 'get_entity_state', entity='spindle_motor')
    assert missing.result.result == Result.RESULT_NOT_FOUND
    assert 'deck, rotor' in missing.result.error_message
    reply = call(plant, srv.GetEntities, 'get_entities')
    assert reply.entities[:2] == ['deck', 'rotor']
    balls = plant.call(srv.GetEntities, f'{SIM}/get_entities', srv.GetEntities.Request(
        filters=EntityFilters(filter='^ball_')))
    assert balls.entities == reply.entities[2:]
    sphere = srv.GetEntities.Request()
    sphere.filters.bounds.type = Bounds.TYPE_SPHERE
    sphere.filters.bounds.points = [_vec(0, 0, 0), _vec(1e-3, 0, 0)]   # centre, radius
    near = plant.call(srv.GetEntities, f'{SIM}/get_entities', sphere)
    assert near.result.result == OK and near.entities == ['deck', 'rotor']
    box = srv.GetEntities.Request()
    box.filters.bounds.type = Bounds.TYPE_BOX
    box.filters.bounds.points = [_vec(0, 0, 0), _vec(1, 1, 1)]
    refused = plant.call(srv.GetEntities, f'{SIM}/get_entities', box)
    assert refused.result.result == Result.RESULT_FEATURE_UNSUPPORTED


def _vec(x, y, z):
    from geometry_msgs.msg import Vector3
    return Vector3(x=float(x), y=float(y), z=float(z))


def test_set_entity_state_moves_a_ball_and_the_deck_and_refuses_the_rest(plant):
    states = plant.collect(JointState, 'joint_states')
    entities = _entity_states(plant)
    # Ball 1 half a turn on: its angle in joint_states after the next step follows.
    ball = entities['ball_1']
    c = entities['deck'].pose.position
    p = ball.pose.position
    moved = EntityState()
    moved.header.frame_id = 'base'
    moved.pose.position.x = c.x - (p.x - c.x)
    moved.pose.position.y = c.y - (p.y - c.y)
    moved.pose.position.z = p.z
    deck_v = entities['deck'].twist.linear
    moved.twist.linear = deck_v
    reply = call(plant, srv.SetEntityState, 'set_entity_state', entity='ball_1', state=moved)
    assert reply.result.result == OK, reply.result.error_message
    after = call(plant, srv.GetEntityState, 'get_entity_state', entity='ball_1').state
    assert math.isclose(after.pose.position.x, moved.pose.position.x, abs_tol=1e-9)
    assert math.isclose(after.pose.position.y, moved.pose.position.y, abs_tol=1e-9)
    # The deck: displaced and at rest.
    deck = EntityState()
    deck.pose.position.x = 1e-4
    deck.pose.orientation.w = 1.0
    assert call(plant, srv.SetEntityState, 'set_entity_state', entity='deck',
                state=deck).result.result == OK
    assert step(plant, 1).result == OK
    plant.wait(lambda: states, 'a step')
    # Refusals, each with its reason.
    R = srv.SetEntityState.Response
    off = EntityState()
    off.pose.position.x = 1.0
    off.pose.orientation.w = 1.0
    refused = call(plant, srv.SetEntityState, 'set_entity_state', entity='ball_2', state=off)
    assert refused.result.result == R.INVALID_POSE and 'race' in refused.result.error_message
    rotor = call(plant, srv.SetEntityState, 'set_entity_state', entity='rotor', state=deck)
    assert rotor.result.result == Result.RESULT_OPERATION_FAILED
    assert 'speed_cmd' in rotor.result.error_message
    deck.header.frame_id = 'deck'
    framed = call(plant, srv.SetEntityState, 'set_entity_state', entity='deck', state=deck)
    assert framed.result.result == Result.RESULT_OPERATION_FAILED
    nowhere = call(plant, srv.SetEntityState, 'set_entity_state', entity='ball_9', state=deck)
    assert nowhere.result.result == Result.RESULT_NOT_FOUND


@pytest.mark.slow
def test_quitting_shuts_the_node_down_cleanly():
    proc = subprocess.Popen(
        [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args', '-r', '__ns:=/quit',
         '-p', 'real_time_factor:=0.0', '-p', 'start_paused:=true'],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node('quitter', context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    try:
        client = node.create_client(srv.SetSimulationState,
                                    '/quit/abb_simulator/set_simulation_state')
        deadline = time.monotonic() + DEADLINE_S
        while not client.service_is_ready():
            assert time.monotonic() < deadline, 'timed out after waiting for the node'
            time.sleep(0.1)
        future = client.call_async(srv.SetSimulationState.Request(
            state=SimulationState(state=SimulationState.STATE_QUITTING)))
        executor.spin_until_future_complete(future, timeout_sec=DEADLINE_S)
        assert future.result().result.result == OK
        assert proc.wait(timeout=DEADLINE_S) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=ctx)
    assert 'Traceback' not in proc.communicate()[0]

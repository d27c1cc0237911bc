"""Hostile requests to the simulator's simulation_interfaces services never kill or freeze it.

Over real DDS, as test_simulation_interfaces_node.py: the simulator node in process, a client
node calling it with the standard's generated types. Claims: each bad request gets one reply
whose message names the field and what is valid; nothing is logged as a traceback; the node
answers the next request and keeps publishing joint_states.
"""

import time

import pytest
from sensor_msgs.msg import JointState
from test_simulator_node import Plant

srv = pytest.importorskip('simulation_interfaces.srv', reason='simulation_interfaces is not '
                          'built (needs cmake and a C/C++ compiler)')
from simulation_interfaces.msg import EntityFilters, Result  # noqa: E402

from abb_ros.nodes.simulator.simulation_interfaces import MAX_FILTER_CHARS  # noqa: E402

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


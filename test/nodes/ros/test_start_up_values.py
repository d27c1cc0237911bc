"""The nodes' start-up values are read through rclpy's public API, over real rclpy and DDS.

``ros_params.start_up_values`` reads the ``-p``/``--params-file`` values and a node's
``parameter_overrides`` as they were given (an integer for a double, None for rcl's empty
list) before anything is declared; reading them declares nothing and publishes no parameter
event, so the declaration that follows is the only one the graph sees. ``declare`` then takes
them strictly: an integer for a double becomes the double, ``[]`` an empty array even where
the default is not empty.
"""

import time

import pytest
import rclpy
from rcl_interfaces.msg import ParameterEvent, ParameterType
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_parameter_events

from abb_ros.model.parameters.params import ParamError
from abb_ros.nodes.ros import ros_params
from abb_ros.nodes.ros.parameter_table import specs_for

pytestmark = pytest.mark.ros

DEADLINE_S = 20.0
ARGS = ['node', '--ros-args', '-p', 'drive.k:=4000', '-p', 'record.topics:=[]',
        '-p', 'seed:=abc', '-p', 'topics:=[]']
SPECS = {**specs_for('simulator'), **specs_for('recorder')}
"""{ROS name: spec}: the simulator's and the recorder's."""


@pytest.fixture
def context():
    ctx = rclpy.Context()
    rclpy.init(args=ARGS, context=ctx)
    yield ctx
    rclpy.shutdown(context=ctx)


def _node(context, name='probed', **kwargs):
    return Node(name, context=context, **kwargs)


def test_start_up_values_are_read_as_given_and_leave_nothing_declared(context):
    """Command-line and constructor overrides come back raw; names without one are absent."""
    node = _node(context, parameter_overrides=[Parameter('drive.c', value=2)])
    try:
        names = ['drive.k', 'drive.c', 'drive.m', 'record.topics', 'seed']
        values = ros_params.start_up_values(node, names)
        assert values == {'drive.k': 4000, 'drive.c': 2, 'record.topics': None, 'seed': 'abc'}
        assert not any(node.has_parameter(name) for name in names)
    finally:
        node.destroy_node()


def test_declare_takes_an_int_for_a_double_and_an_empty_list_as_an_empty_array(context):
    """-p drive.k:=4000 is 4000.0; -p topics:=[] empties a non-empty default."""
    node = _node(context)
    try:
        ros_params.declare(node, {n: SPECS[n] for n in ('drive.k', 'record.topics', 'topics')})
        k, record, topics = node.get_parameters(['drive.k', 'record.topics', 'topics'])
        assert (k.type_, k.value) == (Parameter.Type.DOUBLE, 4000.0)
        assert (record.type_, record.value) == (Parameter.Type.STRING_ARRAY, [])
        assert (topics.type_, topics.value) == (Parameter.Type.STRING_ARRAY, [])
        assert SPECS['topics'].default != []   # so the empty list came from -p
        assert node.describe_parameter('drive.k').type == ParameterType.PARAMETER_DOUBLE
    finally:
        node.destroy_node()


def test_a_bad_start_up_value_is_refused_naming_the_parameter(context):
    """-p seed:=abc raises the one-line ParamError naming seed, and seed stays undeclared."""
    node = _node(context)
    try:
        with pytest.raises(ParamError, match="'seed' = 'abc'"):
            ros_params.declare(node, {'seed': SPECS['seed']})
        assert not node.has_parameter('seed')
    finally:
        node.destroy_node()


def test_reading_start_up_values_publishes_no_parameter_event(context):
    """A listener sees exactly one new drive.k (the declaration), never the probe's."""
    node = _node(context)
    listener = _node(context, 'listener')
    events = []
    listener.create_subscription(
        ParameterEvent, '/parameter_events',
        lambda e: events.append(e) if e.node == node.get_fully_qualified_name() else None,
        qos_profile_parameter_events)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(listener)
    try:
        deadline = time.monotonic() + DEADLINE_S
        while listener.count_publishers('/parameter_events') < 2 or \
                node.count_subscribers('/parameter_events') < 1:
            assert time.monotonic() < deadline, 'timed out after 20 s waiting for discovery'
            executor.spin_once(timeout_sec=0.05)
        time.sleep(0.5)   # the reliable reader matched: events published from now arrive
        ros_params.declare(node, {'drive.k': SPECS['drive.k']})
        while not events:
            assert time.monotonic() < deadline, 'timed out after 20 s waiting for the event'
            executor.spin_once(timeout_sec=0.05)
        for _ in range(20):   # anything published after the declaration would arrive now
            executor.spin_once(timeout_sec=0.05)
        new = [(p.name, p.value.type, p.value.double_value)
               for e in events for p in e.new_parameters]
        assert new == [('drive.k', ParameterType.PARAMETER_DOUBLE, 4000.0)]
        assert not any(e.changed_parameters or e.deleted_parameters for e in events)
    finally:
        executor.shutdown()
        listener.destroy_node()
        node.destroy_node()

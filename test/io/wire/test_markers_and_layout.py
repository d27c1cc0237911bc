"""visualization/markers geometry (no ROS middleware) and the shipped Foxglove layout."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker, MarkerArray

from abb_ros.io.wire import markers, ros_messages
from abb_ros.io.wire.markers import (
    DECK_THICKNESS,
    ROTOR_HEIGHT,
    ball_radius,
    marker_array,
    marker_poses,
)
from abb_ros.io.wire.topics import MARKERS
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.sensors.imu import euler_quaternion, euler_rotation

ROOT = Path(__file__).resolve().parents[3]
LAYOUT = ROOT / 'config' / 'foxglove_layout.json'
ANALYSIS_TOPICS = {'stability/margin'}


def _state(n=3):
    p = DriveParams(n=n)
    y = initial_state(p, 500.0, theta0=0.7)
    y[1:7] = [2e-4, -1e-4, 5e-5, 1e-3, -2e-3, 3e-3]
    return p, y


def test_the_deck_box_rotor_and_balls_ride_on_the_exaggerated_deck_pose():
    p, y = _state()
    k = 100.0
    poses = marker_poses(y, p, k)
    assert [kind for kind, _, _ in poses] == [Marker.CUBE, Marker.CYLINDER] + [Marker.SPHERE] * 3
    R_k = euler_rotation(*(k * y[4:7]))
    C_k = k * y[1:4]
    q_k = euler_quaternion(*(k * y[4:7]))
    deck, rotor = poses[0], poses[1]
    np.testing.assert_allclose(deck[1][:3], C_k + R_k @ [0, -p.d, -DECK_THICKNESS / 2])
    np.testing.assert_allclose(rotor[1][:3], C_k + R_k @ [0, 0, ROTOR_HEIGHT / 2])
    assert deck[2] == (p.a, p.b, DECK_THICKNESS)
    for _, pose, _ in poses:
        np.testing.assert_allclose(pose[3:], q_k)
    for i, (_, pose, scale) in enumerate(poses[2:]):
        psi = y[0] + y[7 + i]
        local = [p.R * math.cos(psi), p.R * math.sin(psi), ROTOR_HEIGHT / 2]
        np.testing.assert_allclose(pose[:3], C_k + R_k @ local)
        assert scale[0] == pytest.approx(2 * ball_radius(p.m))


def test_a_ball_of_table1_mass_is_a_steel_ball_of_about_2_4_mm_radius():
    assert ball_radius(DriveParams().m) == pytest.approx(2.36e-3, rel=0.01)


def _reference_marker_array(stamp_ns, y, p, k) -> MarkerArray:
    """The rclpy message that marker_array's bytes must serialise (built field by field)."""
    out = MarkerArray()
    for i, (kind, pose, scale) in enumerate(marker_poses(y, p, k)):
        m = Marker(ns='abb', id=i, type=kind, action=Marker.ADD)
        m.header.frame_id = ros_messages.FRAME_BASE
        m.header.stamp = ros_messages.time_msg(stamp_ns)
        (m.pose.position.x, m.pose.position.y, m.pose.position.z, m.pose.orientation.x,
         m.pose.orientation.y, m.pose.orientation.z, m.pose.orientation.w) = pose
        m.scale.x, m.scale.y, m.scale.z = scale
        m.color.r, m.color.g, m.color.b, m.color.a = markers._COLOURS[kind]
        out.markers.append(m)
    return out


@pytest.mark.parametrize('n', [1, 2, 10])
def test_the_marker_bytes_are_rclpys_serialisation_of_the_marker_array(n):
    """Same length as rclpy's serialisation and the same message read back (rclpy leaves
    its padding bytes uninitialised, so the bytes themselves may differ there; the colours
    are float32 on the wire)."""
    p, y = _state(n=n)
    data = marker_array(1_500_000_123, y, p, 100.0)
    reference = serialize_message(_reference_marker_array(1_500_000_123, y, p, 100.0))
    assert len(data) == len(reference)
    assert deserialize_message(data, MarkerArray) == deserialize_message(reference, MarkerArray)


def test_the_marker_array_holds_one_marker_per_body_in_frame_base():
    p, y = _state(n=2)
    msg = deserialize_message(marker_array(1_500_000_000, y, p, 100.0), MarkerArray)
    assert [m.id for m in msg.markers] == [0, 1, 2, 3]
    assert {m.header.frame_id for m in msg.markers} == {ros_messages.FRAME_BASE}
    assert {(m.header.stamp.sec, m.header.stamp.nanosec) for m in msg.markers} == \
        {(1, 500_000_000)}
    assert all(m.color.a > 0 and m.action == Marker.ADD for m in msg.markers)


def _layout_topics(layout) -> set[str]:
    topics = set()
    for panel_id, config in layout['configById'].items():
        topics |= set(config.get('topics', {}))
        for path in config.get('paths', []):
            topics.add(path['value'].split('.', 1)[0])
    return topics


def test_the_foxglove_layout_is_json_whose_panels_name_topics_the_bench_publishes():
    layout = json.loads(LAYOUT.read_text())
    published = {'/' + t.lstrip('/') for t in
                 [*ros_messages.TOPIC_TYPES, MARKERS, *ANALYSIS_TOPICS]}
    topics = _layout_topics(layout)
    assert topics and topics <= published, topics - published
    assert {'/visualization/markers', '/joint_states', '/spindle/speed', '/deck/pose',
            '/stability/margin'} <= topics
    kinds = {panel_id.split('!')[0] for panel_id in layout['configById']}
    assert kinds == {'3D', 'Plot', 'Parameters', 'Publish'}
    [publish] = [c for k, c in layout['configById'].items() if k.startswith('Publish!')]
    assert (publish['topicName'], publish['datatype']) == ('/spindle/speed_cmd',
                                                           'std_msgs/msg/Float64')


def test_the_foxglove_layout_tree_names_every_panel_once():
    layout = json.loads(LAYOUT.read_text())

    def leaves(node):
        if isinstance(node, str):
            return [node]
        return leaves(node['first']) + leaves(node['second'])

    assert sorted(leaves(layout['layout'])) == sorted(layout['configById'])


STUDIO_AXIS_LENGTH = 0.2
"""[m] Foxglove Studio 1.48's frame axes at axis scale 1 (its Axis: shaft 0.154 + head 0.046)."""


def test_the_3d_panels_frame_axes_stay_inside_the_race_so_the_balls_show():
    """At Studio's default scale the axes of frame ``base`` (through the spin axis, in the
    balls' plane) are 0.2 m long and hide the 15 mm race; the layout scales them to the drive."""
    layout = json.loads(LAYOUT.read_text())
    [three_d] = [c for k, c in layout['configById'].items() if k.startswith('3D!')]
    transforms = three_d['scene']['transforms']
    p = DriveParams()
    inner_edge = p.R - ball_radius(p.m)
    assert STUDIO_AXIS_LENGTH * transforms['axisScale'] < inner_edge
    assert transforms['labelSize'] < ROTOR_HEIGHT


def test_every_titled_panel_keeps_its_title_in_lichtblick_too():
    """Studio 1.48 shows a panel's ``title``/``foxglovePanelTitle``; Lichtblick 1.28 reads
    ``lichtblickPanelTitle`` only (its toolbar said "Plot" for each plot without it)."""
    layout = json.loads(LAYOUT.read_text())
    titled = {k: c for k, c in layout['configById'].items()
              if 'title' in c or 'foxglovePanelTitle' in c}
    assert len(titled) >= 5
    for panel_id, config in titled.items():
        title = config.get('foxglovePanelTitle', config.get('title'))
        assert config.get('lichtblickPanelTitle') == title, panel_id

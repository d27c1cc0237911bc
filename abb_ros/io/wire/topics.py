"""Every topic of abb_ros, once: name, message type, frame and when it is published.

The simulator node's publishers, the headless run's bag topics and the recorder's default
topics are all derived from :data:`TOPICS` (docs/ros_api.md lists them for users). Names are
relative (resolved in the node's namespace) unless they start with '/'. Only strings here: no
message package or rclpy is imported (:func:`message_class` imports a type when asked).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

__all__ = ['JOINT_STATES', 'JOINT_STATES_THROTTLE', 'DECK_POSE', 'DECK_TWIST', 'DECK_IMU',
           'SPINDLE_SPEED', 'CLOCK_TOPIC', 'MARKERS', 'STABILITY_MARGIN', 'DIAGNOSTICS',
           'SPEED_CMD', 'CURRENT_CMD', 'FRAME_BASE', 'FRAME_DECK', 'STATE', 'IMU', 'CLOCK',
           'EVENT', 'SPEED', 'COMMAND', 'THROTTLED', 'SAMPLED', 'Topic', 'TOPICS', 'by_name',
           'published_by', 'sampled_topics', 'recorded_topics', 'message_class']

FRAME_BASE = 'base'
"""Fixed frame of the drive's base (the deck's rest position)."""

FRAME_DECK = 'deck'
"""Frame attached to the deck at its mass centre C."""

STATE = 'state'
"""Rate role: published from the state at ``publish_rate_hz``."""
IMU = 'imu'
"""Rate role: published at the IMU's own rate (``imu.rate_hz``)."""
CLOCK = 'clock'
"""Rate role: published with every sample once the simulator publishes /clock."""
EVENT = 'event'
"""Rate role: published when something changes (verdicts, faults) or at a low fixed rate."""
SPEED = 'speed'
"""Rate role: with the state samples, when the speed sensor has a reading."""
COMMAND = 'command'
"""Rate role: an input, published by the user and subscribed by the simulator."""
THROTTLED = 'throttled'
"""Rate role: a copy of a state topic at a lower rate (``joint_states_throttle_hz``), for
readers in other processes that need the latest state, not every one (the analysis node)."""

SAMPLED = (CLOCK, STATE, IMU, SPEED)
"""Roles of the topics a simulation sample produces (what a headless bag holds)."""


JOINT_STATES = 'joint_states'
"""Spindle and ball angles and rates (sensor_msgs/JointState)."""
JOINT_STATES_THROTTLE = 'joint_states_throttle'
"""Every joint_states message that opens a slot of 1 / joint_states_throttle_hz (topic_tools'
name for a throttled topic)."""
DECK_POSE = 'deck/pose'
"""The deck's pose in the base frame."""
DECK_TWIST = 'deck/twist'
"""The deck's twist in its own frame."""
DECK_IMU = 'deck/imu'
"""The IMU on the deck."""
SPINDLE_SPEED = 'spindle/speed'
"""The FG speed sensor's measured spindle speed."""
CLOCK_TOPIC = '/clock'
"""Simulated time, when the simulator owns it."""
MARKERS = 'visualization/markers'
"""The drive's MarkerArray."""
STABILITY_MARGIN = 'stability/margin'
"""The analysis node's stability margin."""
DIAGNOSTICS = '/diagnostics'
"""Status of the nodes."""
SPEED_CMD = 'spindle/speed_cmd'
"""Spindle speed command (input of the simulator)."""
CURRENT_CMD = 'spindle/current_cmd'
"""Motor current command, torque mode (input of the simulator)."""


@dataclass(frozen=True)
class Topic:
    """One topic: ``frame`` is the header.frame_id of a stamped message, None if unstamped."""

    name: str
    type: str
    frame: str | None
    rate: str
    publishers: tuple[str, ...]
    recorded: bool = True       # in the recorder's default topics


TOPICS = (
    Topic(JOINT_STATES, 'sensor_msgs/msg/JointState', '', STATE, ('simulator',)),
    Topic(DECK_POSE, 'geometry_msgs/msg/PoseStamped', FRAME_BASE, STATE, ('simulator',)),
    Topic(DECK_TWIST, 'geometry_msgs/msg/TwistStamped', FRAME_DECK, STATE, ('simulator',)),
    Topic(DECK_IMU, 'sensor_msgs/msg/Imu', FRAME_DECK, IMU, ('simulator',)),
    Topic(SPINDLE_SPEED, 'std_msgs/msg/Float64', None, SPEED, ('simulator',)),
    Topic(CLOCK_TOPIC, 'rosgraph_msgs/msg/Clock', None, CLOCK, ('simulator',), recorded=False),
    Topic(MARKERS, 'visualization_msgs/msg/MarkerArray', FRAME_BASE, EVENT,
          ('simulator',)),
    Topic(STABILITY_MARGIN, 'std_msgs/msg/Float64', None, EVENT, ('analysis',)),
    Topic(DIAGNOSTICS, 'diagnostic_msgs/msg/DiagnosticArray', None, EVENT,
          ('simulator', 'analysis')),
    Topic(SPEED_CMD, 'std_msgs/msg/Float64', None, COMMAND, ()),
    Topic(CURRENT_CMD, 'std_msgs/msg/Float64', None, COMMAND, ()),
    Topic(JOINT_STATES_THROTTLE, 'sensor_msgs/msg/JointState', '', THROTTLED, ('simulator',),
          recorded=False),
)
"""Every topic. The simulator creates its publishers, a headless bag its topics (the order is
part of the bag's bytes) and the recorder lists its defaults in this order."""


def by_name(name: str) -> Topic:
    """Return the :class:`Topic` called ``name`` (KeyError if there is none)."""
    for topic in TOPICS:
        if topic.name == name:
            return topic
    raise KeyError(name)


def published_by(node: str) -> tuple[Topic, ...]:
    """Return the topics ``node`` ('simulator' or 'analysis') publishes, in TOPICS order."""
    return tuple(t for t in TOPICS if node in t.publishers)


def sampled_topics() -> tuple[Topic, ...]:
    """Return the topics produced by a simulation sample (a headless run writes exactly these)."""
    return tuple(t for t in TOPICS if t.rate in SAMPLED)


def recorded_topics() -> tuple[Topic, ...]:
    """Return the recorder's default topics."""
    return tuple(t for t in TOPICS if t.recorded)


def message_class(type_name: str):
    """Return the Python message class of ``pkg/msg/Name`` (imports the message package)."""
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)

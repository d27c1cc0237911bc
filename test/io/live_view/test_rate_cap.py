"""The live view's rate cap: what of a 1 kHz topic its viewers get.

Claims: capped at ``max_rate_hz``, a channel sends the first message of each slot of
1 / max_rate_hz of the stamps, evenly spaced, and every other message of that same stamp;
slower topics and a cap of 0 send every message; a cap that is negative or not finite is
refused; the simulator node serves at ``live_view.max_rate_hz`` (100 Hz by default).
"""

from __future__ import annotations

import math
import struct

import pytest

from abb_ros.io.live_view.rate_cap import DEFAULT_MAX_RATE_HZ, RateCap, slot_ns
from abb_ros.io.live_view.server import LiveView

MS = 1_000_000


class Queue:
    """A connection's outbox: the frames the server would send, as (subscription, stamp)."""

    def __init__(self):
        self.frames = []

    def queue(self, frame: bytes) -> int:
        """Take one frame (nothing falls out)."""
        self.frames.append(struct.unpack_from('<BIQ', frame)[1:])
        return 0


@pytest.fixture
def view():
    """A LiveView capped at 100 Hz, with a viewer subscribed to two topics."""
    live = LiveView(port=0, max_rate_hz=100.0)
    live.add_topic('joint_states', 'sensor_msgs/msg/JointState')
    live.add_topic('diagnostics', 'diagnostic_msgs/msg/DiagnosticArray')
    viewer = Queue()
    live.subscribe(viewer, 1, live._channels['/joint_states'])
    live.subscribe(viewer, 2, live._channels['/diagnostics'])
    live.viewer = viewer
    yield live
    live.close()


def test_a_1_khz_topic_reaches_the_viewer_at_the_cap_evenly(view):
    start = 1_700_000_000 * 10 ** 9 + 3 * MS   # a wall-clock stamp, mid-slot
    for k in range(1000):
        view.write('joint_states', b'\0\1\0\0', start + k * MS)
    stamps = [stamp for _, stamp in view.viewer.frames]
    assert len(stamps) == 101   # the first, then the first of each slot of 10 ms
    assert stamps[0] == start and stamps[1] % (10 * MS) == 0
    assert {b - a for a, b in zip(stamps[1:], stamps[2:])} == {10 * MS}


def test_messages_of_one_stamp_all_pass_and_slower_topics_keep_every_message(view):
    for k in range(10):   # /diagnostics at 2 Hz, two statuses a stamp
        view.write_many([('diagnostics', b'\0\1\0\0'), ('diagnostics', b'\0\1\0\0')],
                        k * 500 * MS)
    assert len(view.viewer.frames) == 20


def test_a_cap_of_0_sends_every_message_and_a_bad_cap_is_refused():
    cap = RateCap()
    assert all(cap.keeps(k * MS, slot_ns(0)) for k in range(1000))
    for bad in (-1.0, math.nan, math.inf, '100'):
        with pytest.raises(ValueError, match='max_rate_hz'):
            slot_ns(bad)
    assert slot_ns(1e-300) == 2 ** 62 and slot_ns(1e12) == 1


@pytest.mark.ros
def test_the_simulator_node_serves_at_live_view_max_rate_hz():
    from test_simulator_node import Plant
    for value, slot in ((None, 10 * MS), (250.0, 4 * MS), (0.0, 0)):
        extra = {} if value is None else {'live_view.max_rate_hz': value}
        plant = Plant(**{'live_view.enabled': True, 'live_view.port': 0, **extra})
        try:
            assert plant.sim.live.view._slot_ns == slot
        finally:
            plant.close()
    assert DEFAULT_MAX_RATE_HZ == 100.0

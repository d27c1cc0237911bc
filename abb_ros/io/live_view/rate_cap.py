"""How many messages a second of each topic the live view sends to its viewers.

A browser viewer parses every message on its page's one thread: Foxglove Studio 1.48 in
chromium on 2 cores, fed 3,000 messages/s (``joint_states``, ``deck/pose`` and
``spindle/speed`` at 1 kHz), showed them 1-2 s late (median) and stalled for tens of seconds.
Capped at 100 messages/s a topic, the same page showed them 24-211 ms late (median of
three runs under load 3-8; p95 220-950 ms, the page drawing 1-2 frames/s with software WebGL;
test/io/live_view/test_studio_viewer.py). So a channel sends the first
message of each slot of ``1 / max_rate_hz`` seconds of its stamps (simulated time, as the
markers' ``visualization.rate_hz``), and the other messages of that same stamp (the
simulator's two ``/diagnostics`` statuses); the rest are not sent to viewers (the ROS topics
and the bag keep every one). A signal faster than half the cap is aliased in the viewer's
plots (the deck's whirl at the spindle frequency, 129 Hz at 811 rad/s); a cap of 0 sends
every message.
"""

from __future__ import annotations

__all__ = ['DEFAULT_MAX_RATE_HZ', 'MAX_RATE_VALID', 'RateCap', 'slot_ns']

import math

DEFAULT_MAX_RATE_HZ = 100.0
"""The most messages of one topic a viewer gets a second of stamps (``live_view.max_rate_hz``)."""
MAX_RATE_VALID = 'a finite rate >= 0 Hz (0: every message)'


def slot_ns(max_rate_hz: float) -> int:
    """Return the slot of a cap of ``max_rate_hz`` [ns] (0: no cap); ValueError if invalid."""
    if not isinstance(max_rate_hz, (int, float)) or not math.isfinite(max_rate_hz) \
            or max_rate_hz < 0:
        raise ValueError(f'max_rate_hz {max_rate_hz!r} is not {MAX_RATE_VALID}')
    return 0 if max_rate_hz == 0 else max(1, round(min(1e9 / max_rate_hz, 2 ** 62)))


class RateCap:
    """Which messages of one channel are sent under a cap (see the module docstring)."""

    def __init__(self):
        self._sent = (None, None)   # (slot, stamp) of the last message sent

    def keeps(self, stamp_ns: int, slot: int) -> bool:
        """Whether the message of ``stamp_ns`` is sent with slots of ``slot`` ns (0: all)."""
        if slot == 0 or stamp_ns == self._sent[1]:
            return True
        which = stamp_ns // slot
        if which == self._sent[0]:
            return False
        self._sent = (which, stamp_ns)
        return True

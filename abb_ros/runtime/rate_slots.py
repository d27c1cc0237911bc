"""Publishing a stream at a lower rate: the first sample of each slot of simulated time.

The markers (``visualization.rate_hz``) and ``joint_states_throttle``
(``joint_states_throttle_hz``) are published with the state sample that opens a new slot of
``1 / rate`` seconds of its stamp, so that they follow simulated time at any real-time factor.
"""

from __future__ import annotations

__all__ = ['MAX_SLOT_NS', 'RateSlots']


MAX_SLOT_NS = 2 ** 62
"""Longest slot [ns], about 146 years: a rate so low (down to 5e-324 Hz, which the parameters
accept) that 1 / rate overflows has one slot for any stamp, opened by the first."""


class RateSlots:
    """Which stamps open a new slot of ``1 / rate_hz`` (0 or less: none does)."""

    def __init__(self):
        self._slot = None

    def opens(self, stamp_ns: int, rate_hz: float) -> bool:
        """Return whether ``stamp_ns`` opens a slot not seen yet (then it is the last seen)."""
        if rate_hz <= 0.0:
            return False
        slot = stamp_ns // max(1, round(min(1e9 / rate_hz, MAX_SLOT_NS)))
        if slot == self._slot:
            return False
        self._slot = slot
        return True

"""Publishing a stream at a lower rate: the first sample of each slot of simulated time.

The markers (``visualization.rate_hz``) and ``joint_states_throttle``
(``joint_states_throttle_hz``) are published with the state sample that opens a new slot of
``1 / rate`` seconds of its stamp, so that they follow simulated time at any real-time factor.
"""

from __future__ import annotations

__all__ = ['RateSlots']


class RateSlots:
    """Which stamps open a new slot of ``1 / rate_hz`` (0 or less: none does)."""

    def __init__(self):
        self._slot = None

    def opens(self, stamp_ns: int, rate_hz: float) -> bool:
        """Return whether ``stamp_ns`` opens a slot not seen yet (then it is the last seen)."""
        if rate_hz <= 0.0:
            return False
        slot = stamp_ns // round(1e9 / rate_hz)
        if slot == self._slot:
            return False
        self._slot = slot
        return True

"""Standard normals of a numpy Generator taken in blocks, in the generator's own order.

A Generator's normals come one after another from its bit stream, so drawing a block and
handing its numbers out k at a time gives the same numbers, in the same order, as drawing
k at a time (test/model/sensors/test_sensors.py checks it), at a fraction of numpy's
per-call cost. The IMU
noise, the FG edge jitter and the speed-sensor noise all draw through :class:`NormalStream`.
"""

from __future__ import annotations

import numpy as np

__all__ = ['NormalStream', 'BLOCK']

BLOCK = 3072
"""Normals drawn from the generator at a time (256 IMU samples of 12)."""


class NormalStream:
    """The normals of ``rng`` (a numpy Generator), handed out by :meth:`take`."""

    def __init__(self, rng: np.random.Generator, block: int = BLOCK):
        self.rng = rng
        self.block = int(block)
        self._buffer = np.empty(0)
        self._next = 0

    def take(self, k: int) -> np.ndarray:
        """Return the next ``k`` normals (a read-only view; valid until the next call)."""
        end = self._next + k
        if end > self._buffer.size:
            unused = self._buffer[self._next:]
            self._buffer = np.concatenate([unused, self.rng.standard_normal(
                max(self.block, k - unused.size))])
            self._buffer.flags.writeable = False
            self._next, end = 0, k
        out = self._buffer[self._next:end]
        self._next = end
        return out

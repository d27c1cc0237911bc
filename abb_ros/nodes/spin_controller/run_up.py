"""A run-up that crosses the unbalanced speed bands fast and holds only where balls balance.

The speed reference of the example controller (``spin_controller``), pure and stepwise so that
it is tested without ROS: :func:`hold_speed` picks the speed to hold (the target if the
balanced equilibrium is stable there, else the nearest speed that is, with a guard), and
:class:`RunUp` advances the reference towards it at the run-up acceleration, except that a
reference about to enter an unbalanced band
(:func:`abb_ros.model.stability.speed_bands.unbalanced_bands`; below the translational natural
frequency everything is such a band) jumps over it to the far edge plus the guard: the drive then
crosses the band at its own acceleration limit, the fastest it can, and the balls have the least
time to be captured by the deck's whirl.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ['GUARD_WBAR', 'hold_speed', 'in_band', 'RunUp']

GUARD_WBAR = 0.1
"""Distance (in wbar, a fraction of omega0) kept from a band's edge by the hold speed and by
the far side of a jump; the analysis node's WARN guard (speed_bands.BAND_GUARD_WBAR)."""


def in_band(bands, omega: float):
    """Return the band containing omega [rad/s], or None."""
    return next((b for b in bands if b.lo <= omega <= b.hi), None)


def hold_speed(bands, target: float, omega_max: float, guard: float) -> float:
    """Return the speed [rad/s] to hold for ``target``, at least ``guard`` from every band.

    The target itself when it is at least ``guard`` from every band; else the nearest such
    speed in [0, omega_max] (ties: above). Raises ValueError when no speed in range qualifies.
    """
    def clear(w):
        return 0.0 < w <= omega_max and all(w <= b.lo - guard or w >= b.hi + guard
                                            for b in bands)
    if clear(target):
        return target
    candidates = [w for b in bands for w in (b.lo - guard, b.hi + guard) if clear(w)]
    if not candidates:
        raise ValueError(f'no balanced speed in (0, {omega_max:g}] rad/s')
    return min(candidates, key=lambda w: (abs(w - target), -w))


@dataclass
class RunUp:
    """Speed reference [rad/s] that runs up to a hold speed, jumping over the bands.

    From ``omega_ref`` towards ``hold`` at ``accel`` [rad/s^2], landing ``guard`` [rad/s]
    beyond a band's far edge.
    """

    bands: tuple
    hold: float
    accel: float
    guard: float
    omega_ref: float = 0.0

    def step(self, dt: float) -> float:
        """Advance the reference by dt [s]; return it."""
        gap = self.hold - self.omega_ref
        if gap == 0.0:
            return self.omega_ref
        direction = math.copysign(1.0, gap)
        nxt = self.omega_ref + direction * min(self.accel * dt, abs(gap))
        for b in self.bands:
            far = b.hi + self.guard if direction > 0 else b.lo - self.guard
            # The band lies ahead (between here and the hold speed) and the reference is
            # about to enter it (or is in it): jump to the far side.
            ahead = b.hi >= self.omega_ref if direction > 0 else b.lo <= self.omega_ref
            reached = nxt >= b.lo - self.guard if direction > 0 else nxt <= b.hi + self.guard
            beyond = (far - self.hold) * direction <= 0
            if ahead and reached and beyond and (far - nxt) * direction > 0:
                nxt = far
        self.omega_ref = nxt
        return nxt

    @property
    def holding(self) -> bool:
        """True once the reference has reached the hold speed."""
        return self.omega_ref == self.hold

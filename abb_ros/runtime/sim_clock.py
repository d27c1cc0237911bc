"""The simulator's time base: what its stamps are, and when ``/clock`` carries them.

One rule, kept in every mode (docs/time_under_load.md, "The rule"):

1. While ``/clock`` is silent the stamps are the wall clock (to within one publish period:
   the pacing integrates a period up to half a period before it is due).
2. From the first moment simulated time departs from the wall clock (started with a
   real_time_factor other than 1, or later set to one; paused, also by ``start_paused``;
   stepped, which needs a pause; stopped by a fault), ``/clock`` is published with every
   sample, equal to its stamp, for the rest of the run (and once at the held time when a
   pause or a fault is the first departure): it never goes silent again while the plant runs,
   so a consumer on ``use_sim_time`` never sees its time stop.
3. Stamps never go back. Running at real_time_factor 1 on a wall-clock time base (started at
   1), stamps behind the wall clock jump forward to it (after a pause, a slow-down, a slip);
   stamps ahead of it (after a speed-up) cannot rejoin it without going back in time, so they
   go on at wall speed, ahead, and ``/clock`` (rule 2) carries them. Started at any other
   factor the epoch is 0 (simulated time, as in Gazebo) and the stamps never follow the wall.

:class:`SimClock` is that rule and nothing else: the pacing (:mod:`abb_ros.runtime.pacing`)
and the node tell it when the plant runs at which factor (:meth:`SimClock.run`), is held
(:meth:`SimClock.hold`) or drops periods (:meth:`SimClock.slip`). The wall clock is a function
returning integer nanoseconds, so the rule is tested on a fake clock (test/runtime/test_pacing.py);
no rclpy here.
"""

from __future__ import annotations

from typing import Callable

__all__ = ['SimClock']


class SimClock:
    """The stamps ``epoch_ns + steps * dt_ns`` and whether ``/clock`` carries them.

    Parameters
    ----------
    dt_ns : int
        Integration step [ns].
    real_time_factor : float
        The factor at start-up: 1 starts on the wall clock, anything else on simulated time
        from 0.
    wall_ns : callable
        The wall clock [ns].
    """

    def __init__(self, dt_ns: int, real_time_factor: float, wall_ns: Callable[[], int]):
        self.dt_ns = dt_ns
        self._wall_ns = wall_ns
        self.wall_time_base = real_time_factor == 1.0
        """Started at factor 1: the epoch is the wall clock at start and stamps may follow it."""
        self.epoch_ns = 0
        if self.wall_time_base:
            now = wall_ns()
            self.epoch_ns = now - now % dt_ns
        self.on_wall = self.wall_time_base
        """Whether the stamps follow the wall clock now (lag and slips are measured on it)."""
        self.publishes_clock = not self.wall_time_base
        """Whether ``/clock`` is published (rule 2: once True, for good)."""

    @property
    def time_base(self) -> str:
        """What the stamps are now, as /diagnostics says it (value ``time_base``)."""
        if not self.publishes_clock:
            return 'wall clock, no /clock'
        return 'wall clock, on /clock' if self.on_wall else 'simulated, on /clock'

    def stamp_ns(self, steps: int) -> int:
        """Stamp of the state after ``steps`` steps [ns]."""
        return self.epoch_ns + steps * self.dt_ns

    def hold(self) -> bool:
        """Hold the time: the plant stops (pause, fault), departing from the wall clock.

        Return whether ``/clock`` starts now (then the caller publishes the held time on it:
        the last stamp was published without it).
        """
        started = not self.publishes_clock
        self.on_wall = False
        self.publishes_clock = True
        return started

    def run(self, steps: int, real_time_factor: float, period_ns: int) -> None:
        """Run the time from now, at ``steps``, at ``real_time_factor``.

        On the wall-clock time base at factor 1, stamps behind the wall clock jump forward to
        it; stamps ahead of it by more than one publish period (``period_ns``) stay ahead.
        """
        if real_time_factor != 1.0:
            self.hold()
            return
        if not self.wall_time_base:
            return
        lag = self._wall_ns() - self.stamp_ns(steps)
        if lag > 0:
            self.epoch_ns += lag - lag % self.dt_ns
        self.on_wall = lag > -period_ns

    def rewind(self, steps: int) -> bool:
        """Take the step count back from ``steps`` to 0 (a reset of the simulated time).

        On simulated time (started at a factor other than 1) the stamps go back to the epoch,
        0, with it: the reset asks for it (True). On the wall-clock time base stamps never go
        back (rule 3): the epoch moves on by ``steps`` and they carry on (False).
        """
        if self.wall_time_base:
            self.epoch_ns += steps * self.dt_ns
            return False
        return True

    def slip(self, dropped_ns: int) -> None:
        """``dropped_ns`` of simulated time were dropped: stamps on the wall clock jump."""
        if self.on_wall:
            self.epoch_ns += dropped_ns

    def wall_lag_ns(self, steps: int) -> int:
        """How far the stamp of ``steps`` is behind the wall clock now [ns]."""
        return self._wall_ns() - self.stamp_ns(steps)

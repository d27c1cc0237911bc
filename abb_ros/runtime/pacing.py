"""Real-time pacing of the plant: which publish periods are due on the wall clock.

The simulator integrates in publish periods of ``publish_every`` steps of ``dt_ns``. A
:class:`Pacer` turns a steady clock into a number of periods due at each timer tick, at
``real_time_factor`` (simulated seconds per wall second; 0: as fast as possible, nothing is
paced). The stamps ``epoch_ns + steps * dt_ns``, and whether ``/clock`` carries them, are its
:class:`abb_ros.runtime.sim_clock.SimClock` (:attr:`Pacer.clock`), told by :meth:`Pacer.start`
and :meth:`Pacer.hold` when the plant runs and when it stops.

Under load (docs/time_under_load.md) each tick measures how late its first stamp is: behind
the wall clock while the stamps follow it, else behind the pacing schedule. Above
``max_lag_ns`` the missed periods are not caught up but dropped (a slip): the schedule
restarts from now, and stamps on the wall clock jump forward by the dropped time, as after a
pause.

The clocks are functions returning integer nanoseconds, so that the pacing is tested with a
fake clock (test/runtime/test_pacing.py); no rclpy here.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

from abb_ros.runtime.sim_clock import SimClock

__all__ = ['Pacer', 'PacingWindow']


@dataclass(frozen=True)
class PacingWindow:
    """How the plant kept pace over one diagnostics window (and since start)."""

    real_time_factor: float
    """Achieved over the window: simulated time / wall time."""
    since_start: float
    """Achieved over every window in which the plant ran (paused time excluded)."""
    stamp_lag: float
    """Largest stamp lag in the window [s]."""
    slips: int
    """Slips in the window."""


class Pacer:
    """Publish periods due on a steady clock, stamp lag, slips and the achieved rate.

    Parameters
    ----------
    dt_ns : int
        Integration step [ns].
    publish_every : int
        Steps per publish period.
    real_time_factor : float
        Simulated seconds per wall second; 0 runs as fast as possible.
    max_lag_ns : float
        Stamp lag above which missed periods are dropped [ns].
    steady_ns : callable
        The steady clock the ticks are paced on [ns].
    wall_ns : callable
        The wall clock wall-time stamps follow [ns].
    lead : float
        How far ahead of a tick the due count is taken [publish periods]. 0.5 for a timer
        that may fire early (an rclpy timer): a tick early or late by less than half a period
        integrates one period, and a late one may publish the next period up to half a
        period before its stamp. 0 for the plant's thread, whose sleeps never end early: a
        period is due at its stamp, and a wake-up late by less than a period publishes that
        period alone, late by as much.
    """

    def __init__(self, dt_ns: int, publish_every: int, real_time_factor: float,
                 max_lag_ns: float, steady_ns: Callable[[], int],
                 wall_ns: Callable[[], int] = time.time_ns, lead: float = 0.5):
        self.dt_ns = dt_ns
        self.lead = lead
        self.publish_every = publish_every
        self.real_time_factor = real_time_factor
        self.max_lag_ns = max_lag_ns
        self._steady_ns = steady_ns
        self.clock = SimClock(dt_ns, real_time_factor, wall_ns)
        self.overruns = 0          # periods integrated late, caught up in a later tick
        self.slips = 0
        self.slipped_ns = 0        # wall time dropped by slips [ns]
        self.lag_ns = 0            # largest stamp lag in the diagnostics window [ns]
        self.lag_max_ns = 0        # ... since start [ns]
        self._window_slips = 0
        self._anchor = (steady_ns(), 0)
        self._window = (steady_ns(), 0, True)
        self._run_wall_ns = 0      # wall time and steps while running, for the
        self._run_steps = 0        # real_time_factor since start

    def reconfigure(self, real_time_factor: float, publish_every: int,
                    max_lag_ns: float) -> None:
        """Take new parameters; a new rate or period applies from the next :meth:`start`."""
        self.real_time_factor = real_time_factor
        self.publish_every = publish_every
        self.max_lag_ns = max_lag_ns

    @property
    def free_running(self) -> bool:
        """Whether the plant runs as fast as it can (real_time_factor 0: no deadlines)."""
        return self.real_time_factor == 0.0

    @property
    def epoch_ns(self) -> int:
        """Stamp of step 0 [ns]."""
        return self.clock.epoch_ns

    @property
    def publishes_clock(self) -> bool:
        """Whether the node publishes ``/clock`` (with every sample, and while held)."""
        return self.clock.publishes_clock

    @property
    def tick_period_s(self) -> float:
        """Wall time between two paced ticks: one publish period at real_time_factor [s]."""
        return self.publish_every * self.dt_ns / self.real_time_factor * 1e-9

    def deadline_ns(self, steps: int) -> int:
        """Steady time of the next tick on schedule, from ``steps`` [ns].

        ``lead`` periods after the next publish period falls due (:meth:`_anchor_at`), as a
        timer of the publish period started at the anchor would tick: with lead 0, the time
        of the next period's stamp.
        """
        wall0, steps0 = self._anchor
        every = self.publish_every
        following = (steps // every + 1) * every
        due_in_ns = (following - steps0 + self.lead * every) * self.dt_ns / self.real_time_factor
        return wall0 + math.ceil(due_in_ns)

    def stamp_ns(self, steps: int) -> int:
        """Stamp of the state after ``steps`` steps [ns]."""
        return self.clock.stamp_ns(steps)

    def start(self, steps: int) -> None:
        """(Re)start pacing now at ``steps`` (start, resume, rate change, reset).

        The time base follows :class:`SimClock`'s rule: at factor 1 on the wall clock, stamps
        behind it jump forward to it (never back), as after a pause.
        """
        self.clock.run(steps, self.real_time_factor, self.publish_every * self.dt_ns)
        if self.real_time_factor > 0:
            self._anchor_at(steps)

    def hold(self) -> bool:
        """Hold the time: the plant stops (pause, fault) until :meth:`start`.

        ``/clock`` is published from now on. Return whether it starts now (it was silent
        until then).
        """
        return self.clock.hold()

    def rewind(self, steps: int) -> bool:
        """Take the step count back from ``steps`` to 0 (a reset of the simulated time).

        Return :meth:`SimClock.rewind`'s answer: whether the stamps went back with it. The
        caller restarts the pacing (:meth:`start`).
        """
        wall0, steps0, running = self._window
        self._window = (wall0, steps0 - steps, running)
        return self.clock.rewind(steps)

    def _anchor_at(self, steps: int) -> None:
        """Pace from now at ``steps``.

        Ticks come at the publish period in wall time; the due step count is computed
        ``lead`` periods ahead (half a period for a timer, so that ticks early or late by
        less than P/2 integrate exactly one period each).
        """
        wall_period_ns = self.publish_every * self.dt_ns / self.real_time_factor
        self._anchor = (self._steady_ns() - int(wall_period_ns * self.lead), steps)

    def due(self, steps: int) -> int:
        """Publish periods to integrate now, from ``steps`` (0: none due yet).

        More than one is an overrun (catching up); when the first stamp would be more than
        ``max_lag_ns`` late, all but one are dropped instead (a slip).
        """
        wall0, steps0 = self._anchor
        every = self.publish_every
        elapsed = self._steady_ns() - wall0
        due = steps0 + int(elapsed * self.real_time_factor) // self.dt_ns
        periods = due // every - steps // every
        if periods <= 0:
            return 0
        if periods > 1:
            self.overruns += periods - 1
        first = (steps // every + 1) * every      # step of this tick's first stamp
        lag_ns = self._lag_ns(first, due)
        if lag_ns > self.max_lag_ns and periods > 1:
            self._slip(steps, periods - 1)
            periods = 1
            lag_ns = self._lag_ns(first, first)
        self.lag_ns = max(self.lag_ns, lag_ns)
        self.lag_max_ns = max(self.lag_max_ns, lag_ns)
        return periods

    def _lag_ns(self, step: int, due: int) -> int:
        """How late the stamp of ``step`` is published now [ns of wall time].

        Behind the wall clock while the stamps follow it, else behind the pacing schedule
        (``due``).
        """
        if self.clock.on_wall:
            return self.clock.wall_lag_ns(step)
        return int((due - step) * self.dt_ns / self.real_time_factor)

    def _slip(self, steps: int, periods: int) -> None:
        """Drop ``periods`` publish periods the plant could not keep up with.

        The pacing restarts from now; stamps on the wall clock jump forward by them (as after
        a pause).
        """
        every = self.publish_every
        self.slips += 1
        self._window_slips += 1
        dropped_ns = periods * every * self.dt_ns
        self.slipped_ns += int(dropped_ns / self.real_time_factor)
        self.clock.slip(dropped_ns)
        self._anchor_at((steps // every + 1) * every)

    def start_window(self, steps: int) -> None:
        """Open the first diagnostics window now, at ``steps``, the plant running."""
        self._window = (self._steady_ns(), steps, True)

    def close_window(self, steps: int, running: bool) -> PacingWindow:
        """Close the diagnostics window at ``steps`` and open the next one.

        ``running``: whether the plant runs in the next window (not paused, no fault); only
        such windows count for the real_time_factor since start.
        """
        wall_ns = self._steady_ns()
        wall0, steps0, was_running = self._window
        self._window = (wall_ns, steps, running)
        wall = (wall_ns - wall0) * 1e-9
        achieved = (steps - steps0) * self.dt_ns * 1e-9 / wall if wall > 0 else 0.0
        if was_running:
            self._run_wall_ns += wall_ns - wall0
            self._run_steps += steps - steps0
        since_start = (self._run_steps * self.dt_ns / self._run_wall_ns
                       if self._run_wall_ns > 0 else 0.0)
        window = PacingWindow(achieved, since_start, self.lag_ns * 1e-9, self._window_slips)
        self.lag_ns, self._window_slips = 0, 0
        return window

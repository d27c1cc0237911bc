"""Background computation of the analysis node, free of ROS.

A thread that keeps the |lambda|max-versus-speed table
(:func:`abb_ros.model.stability.speed_bands.speed_table`) of the latest drive configuration and,
when idle, the exact multipliers at the current speed.
"""

from __future__ import annotations

import math
import threading
import time

from abb_ros.model.stability import speed_bands

REFINE_TOL_RAD_S = 0.5
"""An exact point computed within this speed [rad/s] of the current one replaces the
interpolated multipliers."""
MEMBER_TOL_RAD = 1e-3
"""An exact point of a family member within this [rad] (every ball) of the wanted member
stands for it; the balls creep along the family, and a new point per creep would be waste."""
REFINE_SETTLE_S = 0.2
"""The exact point is computed once the speed has stayed within REFINE_TOL_RAD_S for this long
[s]: during a ramp the table alone answers (an exact point per update would compete with the
executor for the CPU and triple the p99 latency, benchmarks/bench_analysis.py)."""

class TableWorker:
    """Background thread: the speed table for the latest configuration, then exact points.

    ``request(config)`` and ``want(omega)`` never block; ``table``, ``exact`` and ``error``
    are read by the executor thread (reference assignment is atomic).
    """

    def __init__(self):
        self._cv = threading.Condition()
        self._config = None
        self._config_id = 0
        self._omega = None
        self._member = None
        self._moved_at = 0.0
        self._stop = False
        self.table = None
        self.table_id = 0
        self.exact = None
        self.exact_member = None
        self.error = ''
        self.error_point = ''
        self.busy = False
        self._thread = threading.Thread(target=self._run, name='abb_analysis_table', daemon=True)
        self._thread.start()

    def request(self, config) -> None:
        """Ask for the speed table of ``config`` (a newer request supersedes an older one)."""
        with self._cv:
            self._config = config
            self._config_id += 1
            self._cv.notify()

    def want(self, omega: float, member=None) -> None:
        """Set the current speed [rad/s], refined once it has been steady for REFINE_SETTLE_S.

        ``member``: the family member to evaluate [rad] (speed_bands.member_near_balls),
        None for the table's symmetric fan.
        """
        with self._cv:
            moved = self._omega is None or abs(omega - self._omega) > REFINE_TOL_RAD_S
            if moved:
                self._omega = omega
                self._moved_at = time.monotonic()
            if not _same_member(member, self._member):
                self._member = member
                moved = True
            if moved:
                self._cv.notify()

    def stop(self) -> None:
        """Stop the thread and wait for it (at most 10 s)."""
        with self._cv:
            self._stop = True
            self._cv.notify()
        self._thread.join(timeout=10.0)

    def _needs_point(self) -> bool:
        if self._omega is None or self.table is None or self.table_id != self._config_id:
            return False
        return (self.exact is None or abs(self.exact.omega - self._omega) > REFINE_TOL_RAD_S
                or not _same_member(self._member, self.exact_member))

    def _next_job(self):
        """Wait, under the lock, for a table to compute or a steady speed to refine.

        Return the job, or None to stop.
        """
        while not self._stop:
            if self.table_id != self._config_id:
                self.busy = True
                return self._config_id, self._config, None
            if self._needs_point():
                remaining = self._moved_at + REFINE_SETTLE_S - time.monotonic()
                if remaining <= 0:
                    return self._config_id, self._config, (self._omega, self._member)
                self._cv.wait(remaining)
            else:
                self._cv.wait()
        return None

    def _run(self) -> None:
        while True:
            with self._cv:
                job = self._next_job()
            if job is None:
                return
            config_id, config, point = job
            if point is None:
                self._compute_table(config_id, config)
                continue
            omega, member = point
            try:
                self.exact = speed_bands.refine(self.table, omega, member)
            except Exception as err:  # noqa: BLE001 - keep the interpolated value
                self.exact = None
                self.error_point = f'{type(err).__name__}: {err}'
            self.exact_member = member
            if self.exact is None:  # nothing to refine here: wait for another speed
                with self._cv:
                    if self._omega == omega:
                        self._omega = None

    def _compute_table(self, config_id, config) -> None:
        try:
            table = speed_bands.speed_table(*config)
        except Exception as err:  # noqa: BLE001 - reported as ERROR, the node goes on
            table = None
            self.error = f'analysis failed: {type(err).__name__}: {err}'
        else:
            self.error = ''
        self.exact = None
        self.table, self.table_id = table, config_id
        self.busy = False


def _same_member(a, b) -> bool:
    """Return whether both are None (the fan) or members within MEMBER_TOL_RAD of each other."""
    if a is None or b is None:
        return a is None and b is None
    return len(a) == len(b) and all(abs(math.remainder(x - y, 2 * math.pi)) <= MEMBER_TOL_RAD
                                    for x, y in zip(a, b))

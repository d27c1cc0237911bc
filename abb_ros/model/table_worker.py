"""The analysis node's background computation, free of ROS: a thread that keeps the
|lambda|max-versus-speed table (:func:`abb_ros.model.speed_bands.speed_table`) of the latest
drive configuration and, when idle, the exact multipliers at the current speed."""

from __future__ import annotations

import threading
import time

from abb_ros.model import speed_bands

REFINE_TOL_RAD_S = 0.5
"""An exact point computed within this speed [rad/s] of the current one replaces the
interpolated multipliers."""
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
        self._moved_at = 0.0
        self._stop = False
        self.table = None
        self.table_id = 0
        self.exact = None
        self.error = ''
        self.error_point = ''
        self.busy = False
        self._thread = threading.Thread(target=self._run, name='abb_analysis_table', daemon=True)
        self._thread.start()

    def request(self, config) -> None:
        with self._cv:
            self._config = config
            self._config_id += 1
            self._cv.notify()

    def want(self, omega: float) -> None:
        """The current speed [rad/s]: refined once it has been steady for REFINE_SETTLE_S."""
        with self._cv:
            if self._omega is None or abs(omega - self._omega) > REFINE_TOL_RAD_S:
                self._omega = omega
                self._moved_at = time.monotonic()
                self._cv.notify()

    def stop(self) -> None:
        with self._cv:
            self._stop = True
            self._cv.notify()
        self._thread.join(timeout=10.0)

    def _needs_point(self) -> bool:
        if self._omega is None or self.table is None or self.table_id != self._config_id:
            return False
        return self.exact is None or abs(self.exact.omega - self._omega) > REFINE_TOL_RAD_S

    def _next_job(self):
        """Under the lock: wait until there is a table to compute or a steady speed to refine;
        None to stop."""
        while not self._stop:
            if self.table_id != self._config_id:
                self.busy = True
                return self._config_id, self._config, None
            if self._needs_point():
                remaining = self._moved_at + REFINE_SETTLE_S - time.monotonic()
                if remaining <= 0:
                    return self._config_id, self._config, self._omega
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
            config_id, config, omega = job
            if omega is None:
                self._compute_table(config_id, config)
                continue
            try:
                self.exact = speed_bands.refine(self.table, omega)
            except Exception as err:  # noqa: BLE001 - keep the interpolated value
                self.exact = None
                self.error_point = f'{type(err).__name__}: {err}'
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

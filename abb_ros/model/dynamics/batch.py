"""Batched nonlinear runs: many parameter sets integrated by one compiled kernel call.

The design studies of ``abb-sim sweep`` integrate thousands of drives that differ in their
parameters. :func:`rk4_metrics_batch` advances a batch of B states of the same ball count n,
each with its own packed parameters (``P[b]``, :func:`abb_ros.model.dynamics.kernels.pack_params`)
and spindle profile (``S[b]``), by fixed RK4 steps, and reduces the trajectory inside the kernel to
the metrics a design study asks for, so nothing is sampled or returned per step:

- ``peak_rbar``: the largest rbar = sqrt(X^2 + Y^2 + Z^2)/R seen after any step (Section 5);
- ``time_above``: the time [s] during which rbar exceeded the vibration limit ``rbar_limit``
  (each step whose end state is above the limit counts one dt);
- ``last_above``: the end time [s] of the last step whose rbar exceeded the limit (-inf when
  none has yet); the settle time is this time when the run ends below the limit;
- ``fail_time``: the time [s] of the last good state of a run that failed (NaN otherwise).

The RK4 step with its state check is the single-run kernels'
(:func:`abb_ros.model.dynamics.kernels.stepper.step_uncached`, called per sample, not copied), so a
sample of the batch follows exactly the trajectory
:func:`abb_ros.model.dynamics.kernels.stepper.advance` computes for it alone (the tests compare to
the bit). A sample whose state becomes non-finite or leaves the envelope keeps its last good state
and its status (``kernels.NONFINITE`` / ``ENVELOPE``) and is not advanced further; the others
go on. The kernel is built twice from this source like :mod:`abb_ros.model.dynamics.kernels`:
``JIT`` (numba) and ``PY`` (interpreted).

Metrics are kept across calls (the arrays are updated in place), so a run can be advanced in
segments, e.g. between the spindle-speed commands of a scenario.
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.kernels.layout import OK, P_R, S_OMEGA_CMD, Stages, solver_scratch
from abb_ros.model.dynamics.kernels.stepper import step_uncached
from abb_ros.model.dynamics.state import DECK, PHI
from abb_ros.model.jit import KernelSet

__all__ = ['METRICS', 'PEAK_RBAR', 'TIME_ABOVE', 'LAST_ABOVE', 'new_metrics', 'JIT', 'PY',
           'BatchRun', 'FAIL_TIME']

METRICS = ('peak_rbar', 'time_above', 'last_above', 'fail_time')
PEAK_RBAR, TIME_ABOVE, LAST_ABOVE, FAIL_TIME = 0, 1, 2, 3


def new_metrics(B: int) -> np.ndarray:
    """Metric accumulators for a batch of B runs before the first step, shape (B, 4)."""
    m = np.zeros((B, len(METRICS)))
    m[:, LAST_ABOVE] = -np.inf
    m[:, FAIL_TIME] = np.nan
    return m


kernel = KernelSet(nogil=True, error_model='numpy')


@kernel
def rk4_metrics_batch(Y, P, S, t0, dt, step0, nsteps, rbar_limit, metrics, status):
    """Advance each row Y[b] (a state, shape (2N,)) by nsteps RK4 steps of dt, in place.

    From t = t0 + step0 dt with parameters P[b] and spindle profile S[b], updating metrics[b]
    (:data:`METRICS`) after every step. Rows with status[b] != OK are left alone; a row that
    goes bad gets its status and keeps its last good state. All in place.
    """
    n2 = Y.shape[1]
    n = n2 // 2 - PHI
    stages = Stages(np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2),
                    np.empty(n2))
    solver = solver_scratch(n)
    for b in range(Y.shape[0]):
        if status[b] != OK:
            continue
        y = Y[b]
        Pb = P[b]
        Sb = S[b]
        inv_R = 1.0 / Pb[P_R]
        peak = metrics[b, PEAK_RBAR]
        above = metrics[b, TIME_ABOVE]
        last = metrics[b, LAST_ABOVE]
        for s in range(nsteps):
            t = t0 + (step0 + s) * dt
            st, _ = step_uncached(t, dt, y, n, Pb, Sb, stages, solver)
            if st != OK:
                status[b] = st
                metrics[b, FAIL_TIME] = t
                break
            r = math.sqrt(y[DECK] * y[DECK] + y[DECK + 1] * y[DECK + 1]
                          + y[DECK + 2] * y[DECK + 2]) * inv_R
            if r > peak:
                peak = r
            if r > rbar_limit:
                above += dt
                last = t + dt
        metrics[b, PEAK_RBAR] = peak
        metrics[b, TIME_ABOVE] = above
        metrics[b, LAST_ABOVE] = last


JIT, PY = kernel.build()
"""JIT: the batched kernel compiled with numba (cached on disk), over the compiled single-run
kernels; PY: the same source interpreted, over their Python twin."""


class BatchRun:
    """B runs of drives with the same ball count, advanced together.

    Parameters
    ----------
    params_list : sequence of DriveParams (same n)
    y0 : ndarray, shape (B, 2N)
        Initial states (:func:`abb_ros.model.dynamics.initial.initial_state` per run).
    S : ndarray, shape (B, N_SPINDLE)
        Packed spindle profiles (``ConstantSpeed().pack()``, ``SpindleMotor(...).pack(cmd)``).
    dt : float
        Step [s].
    rbar_limit : float
        Vibration limit of rbar for ``time_above`` and the settle time.
    """

    def __init__(self, params_list, y0, S, dt, rbar_limit, kern=None):
        ns = {p.n for p in params_list}
        if len(ns) != 1:
            raise ValueError(f'a batch needs one ball count, got n in {sorted(ns)}')
        self.n = ns.pop()
        self.kern = kern or JIT
        self.P = np.array([kernels.pack_params(p) for p in params_list])
        self.R = self.P[:, kernels.PARAM_ORDER.index('R')]
        self.Y = np.array(y0, dtype=float, order='C')
        self.S = np.array(S, dtype=float, order='C')
        self.dt = float(dt)
        self.rbar_limit = float(rbar_limit)
        self.steps = 0
        self.metrics = new_metrics(len(params_list))
        self.status = np.zeros(len(params_list), dtype=np.int64)

    def advance(self, nsteps: int) -> None:
        """Advance every good run by nsteps steps."""
        self.kern.rk4_metrics_batch(self.Y, self.P, self.S, 0.0, self.dt, self.steps,
                                    int(nsteps), self.rbar_limit, self.metrics,
                                    self.status)
        self.steps += int(nsteps)

    def set_omega_cmd(self, omega_cmd) -> None:
        """Set the commanded spindle speed(s) [rad/s] of a motor profile (S[:, S_OMEGA_CMD])."""
        self.S[:, S_OMEGA_CMD] = omega_cmd

    @property
    def t(self) -> float:
        """Simulated time [s]."""
        return self.steps * self.dt

    @property
    def rbar(self) -> np.ndarray:
        """The rbar of the current (or last good) state of each run."""
        return np.sqrt(self.Y[:, 1] ** 2 + self.Y[:, 2] ** 2 + self.Y[:, 3] ** 2) / self.R

    @property
    def settle_time(self) -> np.ndarray:
        """Time [s] after which rbar stayed at or below the limit to the end.

        NaN when the run ends above the limit or failed, 0 when it never exceeded it.
        """
        last = self.metrics[:, LAST_ABOVE]
        out = np.where(np.isfinite(last), last, 0.0)
        bad = (self.rbar > self.rbar_limit) | (self.status != kernels.OK)
        return np.where(bad, np.nan, out)

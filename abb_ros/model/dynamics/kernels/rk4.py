"""The classical fourth-order Runge-Kutta step (RK4), written once.

:func:`rk4_stage_point` and :func:`rk4_combine` are its two vector operations (every RK4 step
of the package, the multirate step's fast sub-steps included, uses them); :func:`rk4_after_k1`
is its stage sequence, over the model's right-hand side or, with rolling regimes given, over
that right-hand side with the regimes kept (each law's smooth extension).
"""

from __future__ import annotations

import numpy as np

from abb_ros.model.dynamics.kernels.layout import kernel
from abb_ros.model.dynamics.kernels.rhs import deriv, paper_deriv
from abb_ros.model.dynamics.kernels.rolling_resistance import rolling_deriv


@kernel
def rk4_stage_point(y0, a, k, yt):
    """Set yt = y0 + a k (the state at which a stage's derivative is taken)."""
    for i in range(y0.shape[0]):
        yt[i] = y0[i] + a * k[i]


@kernel
def rk4_combine(y0, h, k1, k2, k3, k4, y):
    """Set y = y0 + h / 6 (k1 + 2 (k2 + k3) + k4), the RK4 step of h (y may be y0)."""
    h6 = h / 6.0
    for i in range(y0.shape[0]):
        y[i] = y0[i] + h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])


@kernel(inline=True)
def stage_deriv(t, y, n, P, S, mode, dy, solver):
    """Fill dy with y' at (t, y): with the rolling regimes ``mode`` kept, or none (empty)."""
    if mode.shape[0] > 0:
        rolling_deriv(t, y, n, P, S, mode, True, dy, solver)
    else:
        deriv(t, y, n, P, S, dy, solver)


@kernel
def rk4_after_k1(t, h, y0, y, n, P, S, mode, stages, solver):
    """Set y to one RK4 step of h from (t, y0), k1 (``stages.k1``, y' at y0) given.

    ``mode``: the rolling regimes kept over the step, or empty (no rolling resistance).
    y may be y0 (in place). A call (the rolling events' three call sites share one compiled
    body); :func:`rk4_substep` has the stages in place instead (:func:`rk4_stages`).
    """
    rk4_stages(t, h, y0, y, n, P, S, mode, stages, solver)


@kernel(inline=True)
def rk4_stages(t, h, y0, y, n, P, S, mode, stages, solver):
    """Run the stage sequence of :func:`rk4_after_k1`, compiled in place where it is called.

    In the paper's path (one RK4 step per time step) a call passing the stage and solver
    tuples costs about a fifth of the step.
    """
    k1, k2, k3, k4, yt = stages.k1, stages.k2, stages.k3, stages.k4, stages.yt
    rk4_stage_point(y0, 0.5 * h, k1, yt)
    stage_deriv(t + 0.5 * h, yt, n, P, S, mode, k2, solver)
    rk4_stage_point(y0, 0.5 * h, k2, yt)
    stage_deriv(t + 0.5 * h, yt, n, P, S, mode, k3, solver)
    rk4_stage_point(y0, h, k3, yt)
    stage_deriv(t + h, yt, n, P, S, mode, k4, solver)
    rk4_combine(y0, h, k1, k2, k3, k4, y)


@kernel(inline=True)
def rk4_substep(t, h, y, n, P, S, stages, solver):
    """Take one RK4 step of h from (t, y) of the whole system, y in place (no state check)."""
    deriv(t, y, n, P, S, stages.k1, solver)
    rk4_stages(t, h, y, y, n, P, S, np.empty(0), stages, solver)


@kernel
def rk4_substeps(t, dt, sub, y, n, P, S, stages, solver):
    """Take ``sub`` RK4 sub-steps of dt / sub of the whole system from (t, y), y in place."""
    h = dt / sub
    for j in range(sub):
        rk4_substep(t + j * h, h, y, n, P, S, stages, solver)


@kernel(inline=True)
def paper_rk4(t, h, y, n, P, S, stages, solver):
    """One RK4 step of h from (t, y), y in place, of :func:`~.rhs.paper_deriv` (in place)."""
    k1, k2, k3, k4, yt = stages.k1, stages.k2, stages.k3, stages.k4, stages.yt
    paper_deriv(t, y, n, P, S, k1, solver)
    rk4_stage_point(y, 0.5 * h, k1, yt)
    paper_deriv(t + 0.5 * h, yt, n, P, S, k2, solver)
    rk4_stage_point(y, 0.5 * h, k2, yt)
    paper_deriv(t + 0.5 * h, yt, n, P, S, k3, solver)
    rk4_stage_point(y, h, k3, yt)
    paper_deriv(t + h, yt, n, P, S, k4, solver)
    rk4_combine(y, h, k1, k2, k3, k4, y)

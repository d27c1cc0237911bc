"""An adaptive Runge-Kutta integrator: Dormand-Prince 5(4) with error control and dense output.

The pair of Dormand & Prince (1980) as in Hairer, Norsett & Wanner, *Solving Ordinary
Differential Equations I*, Sec. II.4-II.6 (the code DOPRI5), and as scipy's ``RK45``: seven
stages, the last evaluated at the new state and reused as the first of the next step (FSAL, six
right-hand sides per step), the fifth-order solution propagated, the embedded fourth-order one
giving the error estimate, and the continuous extension of order 4 that costs no further
right-hand side (Hairer's CONTD5), from which the samples are read at exactly the requested
times. The right-hand side is the model's one, :func:`abb_ros.model.dynamics.kernels.rhs.deriv`.

Step control as scipy's ``solve_ivp`` does it: the error norm is the root mean square of
``err_i / (atol_i + rtol max(|y_i|, |y_new_i|))`` (``atol`` one value per component), a step
is accepted when the norm is at most 1, and the next step is h min(MAX_FACTOR, SAFETY
norm^(-1/5)) (not larger than h just after a rejection; at least MIN_FACTOR h after one). The
first step is scipy's ``select_initial_step`` rule.

The integrator's own state lives in two arrays that the caller keeps between calls, so a run
can be sampled in chunks without restarting: ``ad`` (scalars, indices ``AD_*``) and ``aw``
(rows ``AW_*``: the stages, the new state and the dense-output coefficients of the last step).
``ad[AD_LIVE] = 0`` restarts from the given state (after any change of an input, which the
integrator must not step across). The integrator runs ahead of the last sample to the end of
its last step; a sample is the continuous extension on the step that contains it.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from abb_ros.model.dynamics.kernels.layout import NONFINITE, OK, kernel, solver_scratch
from abb_ros.model.dynamics.kernels.rhs import deriv
from abb_ros.model.dynamics.kernels.stepper import check_state
from abb_ros.model.dynamics.state import PHI

SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
MIN_STEP = 1e-12
"""Smallest step [s]: below it the run stops as non-finite (a singular right-hand side)."""

DP_C = np.array([0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0])
"""The Dormand-Prince tableau, c: where stage i is evaluated, t + c_i h."""
DP_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0],
    [19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0],
    [9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0]])
"""The tableau's a_ij: stage i at y + h sum_j a_ij k_j (row i, stages 1..6)."""
DP_B = np.array([35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0,
                 11.0 / 84.0])
"""The fifth-order weights b_i (also the seventh stage's row: FSAL)."""
DP_E = np.array([71.0 / 57600.0, 0.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0,
                 22.0 / 525.0, -1.0 / 40.0])
"""Fifth- minus fourth-order weights of the seven stages: the error estimate is h sum e_i k_i."""
DP_D = np.array([-12715105075.0 / 11282082432.0, 0.0, 87487479700.0 / 32700410799.0,
                 -10690763975.0 / 1880347072.0, 701980252875.0 / 199316789632.0,
                 -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0])
"""Weights of the continuous extension's last coefficient (Hairer's CONTD5), seven stages."""

# The kernels read the tableau as scalars (constants to numba, sums written out: no loop over
# the zero entries); the same numbers as the arrays above.
C2, C3, C4, C5 = (float(c) for c in DP_C[1:5])
A21 = float(DP_A[1, 0])
A31, A32 = (float(a) for a in DP_A[2, :2])
A41, A42, A43 = (float(a) for a in DP_A[3, :3])
A51, A52, A53, A54 = (float(a) for a in DP_A[4, :4])
A61, A62, A63, A64, A65 = (float(a) for a in DP_A[5, :5])
B1, B3, B4, B5, B6 = (float(DP_B[i]) for i in (0, 2, 3, 4, 5))
E1, E3, E4, E5, E6, E7 = (float(DP_E[i]) for i in (0, 2, 3, 4, 5, 6))
D1, D3, D4, D5, D6, D7 = (float(DP_D[i]) for i in (0, 2, 3, 4, 5, 6))

AD_T, AD_H, AD_LIVE, AD_T_OLD, AD_REJECTED, AD_NFEV, AD_ACCEPTED, AD_REJECTS = range(8)
AD_SIZE = 8
"""``ad``: time of the integrator's state [s], next step [s] (<= 0: choose the first), 1 when
``aw`` holds a live state, start of the last step [s], 1 after a rejection, and the counts of
right-hand sides, accepted and rejected steps."""

AW_K = 0          # rows 0..6: the stages k1..k7 of the step (k7 = f(t_new, y_new))
AW_STAGE = 7      # the state at which a stage is evaluated
AW_Y = 8          # the integrator's state at ad[AD_T]
AW_YNEW = 9       # a step's candidate state
AW_DENSE = 10     # rows 10..14: the continuous extension's coefficients of the last step
AW_ROWS = 15


AdaptiveState = namedtuple('AdaptiveState', ['rtol', 'atol', 'ad', 'aw'])
"""What the integrator keeps between calls: its tolerances (``rtol``, ``atol`` per
component) and its state arrays ``ad`` and ``aw`` (module docstring)."""


def adaptive_buffers(n: int):
    """Return new (ad, aw) for n balls: nothing live, the first step to be chosen."""
    return np.zeros(AD_SIZE), np.zeros((AW_ROWS, 2 * (PHI + n)))


@kernel
def stage(t, y, n, P, S, dy, solver):
    """Fill dy with y' at (t, y): the model's right-hand side, one call site for the stages."""
    deriv(t, y, n, P, S, dy, solver)


@kernel
def error_norm(y, aw, h, rtol, atol):
    """Return the RMS of the scaled error h sum E_i k_i of the candidate step."""
    K = aw[AW_K:AW_K + 7]
    ynew = aw[AW_YNEW]
    total = 0.0
    m = y.shape[0]
    for i in range(m):
        e = h * (E1 * K[0, i] + E3 * K[2, i] + E4 * K[3, i] + E5 * K[4, i] + E6 * K[5, i]
                 + E7 * K[6, i])
        sc = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
        total += (e / sc) ** 2
    return math.sqrt(total / m)


@kernel
def try_step(t, h, n, P, S, rtol, atol, aw, solver):
    """Take a candidate step of h from (t, aw[AW_Y]) with k1 = aw[AW_K]; return its error norm.

    Fills the stages k2..k7 and the candidate aw[AW_YNEW] (k7 at it).
    """
    y, K, yt, ynew = aw[AW_Y], aw[AW_K:AW_K + 7], aw[AW_STAGE], aw[AW_YNEW]
    m = y.shape[0]
    for i in range(m):
        yt[i] = y[i] + h * A21 * K[0, i]
    stage(t + C2 * h, yt, n, P, S, K[1], solver)
    for i in range(m):
        yt[i] = y[i] + h * (A31 * K[0, i] + A32 * K[1, i])
    stage(t + C3 * h, yt, n, P, S, K[2], solver)
    for i in range(m):
        yt[i] = y[i] + h * (A41 * K[0, i] + A42 * K[1, i] + A43 * K[2, i])
    stage(t + C4 * h, yt, n, P, S, K[3], solver)
    for i in range(m):
        yt[i] = y[i] + h * (A51 * K[0, i] + A52 * K[1, i] + A53 * K[2, i] + A54 * K[3, i])
    stage(t + C5 * h, yt, n, P, S, K[4], solver)
    for i in range(m):
        yt[i] = y[i] + h * (A61 * K[0, i] + A62 * K[1, i] + A63 * K[2, i] + A64 * K[3, i]
                            + A65 * K[4, i])
    stage(t + h, yt, n, P, S, K[5], solver)
    for i in range(m):
        ynew[i] = y[i] + h * (B1 * K[0, i] + B3 * K[2, i] + B4 * K[3, i] + B5 * K[4, i]
                              + B6 * K[5, i])
    stage(t + h, ynew, n, P, S, K[6], solver)
    return error_norm(y, aw, h, rtol, atol)


@kernel
def accept(h, aw):
    """Set the dense-output coefficients of the step of h just taken, and move to its end."""
    y, K, ynew, R = aw[AW_Y], aw[AW_K:AW_K + 7], aw[AW_YNEW], aw[AW_DENSE:AW_DENSE + 5]
    for i in range(y.shape[0]):
        diff = ynew[i] - y[i]
        bspl = h * K[0, i] - diff
        R[0, i] = y[i]
        R[1, i] = diff
        R[2, i] = bspl
        R[3, i] = diff - h * K[6, i] - bspl
        R[4, i] = h * (D1 * K[0, i] + D3 * K[2, i] + D4 * K[3, i] + D5 * K[4, i]
                       + D6 * K[5, i] + D7 * K[6, i])
        y[i] = ynew[i]
        K[0, i] = K[6, i]


@kernel
def dense(aw, s, out):
    """Set out to the continuous extension at the fraction s in [0, 1] of the last step."""
    R = aw[AW_DENSE:AW_DENSE + 5]
    s1 = 1.0 - s
    for i in range(out.shape[0]):
        out[i] = R[0, i] + s * (R[1, i] + s1 * (R[2, i] + s * (R[3, i] + s1 * R[4, i])))


@kernel
def rms_scaled(v, y, rtol, atol):
    """Return the RMS of v_i / (atol_i + rtol |y_i|)."""
    total = 0.0
    for i in range(v.shape[0]):
        total += (v[i] / (atol[i] + rtol * abs(y[i]))) ** 2
    return math.sqrt(total / v.shape[0])


@kernel
def initial_step(t, n, P, S, rtol, atol, aw, solver):
    """Return the first step [s] by scipy's select_initial_step rule (order 4 error estimate).

    aw[AW_Y] is the state and aw[AW_K] its derivative; costs one right-hand side.
    """
    y, f0, yt, f1 = aw[AW_Y], aw[AW_K], aw[AW_STAGE], aw[AW_K + 1]
    d0 = rms_scaled(y, y, rtol, atol)
    d1 = rms_scaled(f0, y, rtol, atol)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    for i in range(y.shape[0]):
        yt[i] = y[i] + h0 * f0[i]
    stage(t + h0, yt, n, P, S, f1, solver)
    for i in range(y.shape[0]):
        yt[i] = f1[i] - f0[i]
    d2 = rms_scaled(yt, y, rtol, atol) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** 0.2
    return min(100.0 * h0, h1)


@kernel
def adaptive_step(n, P, S, rtol, atol, ad, aw, solver):
    """Take one accepted step from ad[AD_T] (rejected tries retaken smaller); return a status.

    On success ad[AD_T_OLD], ad[AD_T] bound the step and aw holds its continuous extension.
    """
    t = ad[AD_T]
    h = ad[AD_H]
    rejected = False
    while True:
        if h < MIN_STEP or not math.isfinite(h):
            return NONFINITE
        err = try_step(t, h, n, P, S, rtol, atol, aw, solver)
        ad[AD_NFEV] += 6.0
        if err <= 1.0:
            factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err ** -0.2)
            if rejected:
                factor = min(1.0, factor)
            accept(h, aw)
            ad[AD_T_OLD] = t
            ad[AD_T] = t + h
            ad[AD_H] = h * factor
            ad[AD_ACCEPTED] += 1.0
            return check_state(aw[AW_Y], n)
        # a NaN error norm also lands here and shrinks the step
        factor = MIN_FACTOR if not err < math.inf else max(MIN_FACTOR, SAFETY * err ** -0.2)
        h *= factor
        rejected = True
        ad[AD_REJECTS] += 1.0


@kernel
def adaptive_trajectory(y, t0, dt, step0, nsteps, every, P, S, state, out):
    """Sample the solution every ``every`` steps of dt over nsteps, from t = t0 + step0 dt.

    The samples (at t0 + (step0 + k every) dt, k = 1, 2, ...) go into ``out`` rows and the
    last into y. With ``ad[AD_LIVE]`` 0 the integrator starts from y at the first time. Returns
    (steps done, rows written, status); after a bad state y is the last good sample and the
    integrator is not live. ``state``: an :data:`AdaptiveState`.
    """
    rtol, atol, ad, aw = state.rtol, state.atol, state.ad, state.aw
    n = y.shape[0] // 2 - PHI
    m = y.shape[0]
    solver = solver_scratch(n)
    if ad[AD_LIVE] == 0.0:
        t = t0 + step0 * dt
        for i in range(m):
            aw[AW_Y, i] = y[i]
        stage(t, aw[AW_Y], n, P, S, aw[AW_K], solver)
        ad[AD_NFEV] += 1.0
        ad[AD_T] = t
        ad[AD_T_OLD] = t
        if ad[AD_H] <= 0.0:
            ad[AD_H] = initial_step(t, n, P, S, rtol, atol, aw, solver)
            ad[AD_NFEV] += 1.0
        ad[AD_LIVE] = 1.0
    rows = nsteps // every
    sample = np.empty(m)
    for k in range(1, rows + 1):
        target = t0 + (step0 + k * every) * dt
        while ad[AD_T] < target:
            status = adaptive_step(n, P, S, rtol, atol, ad, aw, solver)
            if status != OK:
                ad[AD_LIVE] = 0.0
                return (k - 1) * every, k - 1, status
        span = ad[AD_T] - ad[AD_T_OLD]
        s = 1.0 if span <= 0.0 else (target - ad[AD_T_OLD]) / span
        dense(aw, min(1.0, max(0.0, s)), sample)
        status = check_state(sample, n)
        if status != OK:
            ad[AD_LIVE] = 0.0
            return (k - 1) * every, k - 1, status
        for i in range(m):
            out[k - 1, i] = sample[i]
            y[i] = sample[i]
    return rows * every, rows, OK

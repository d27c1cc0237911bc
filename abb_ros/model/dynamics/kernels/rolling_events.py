"""Rolling-regime switches located in time within an RK4 step (event location).

Under rolling resistance (:mod:`abb_ros.model.dynamics.kernels.rolling_resistance`) a ball's law
changes where it sticks, slips or breaks free. :func:`rolling_substep` keeps the regimes of a
step's start over the step (so that RK4 keeps its order), and where they ended inside it
locates the switching instant (regula falsi with the Illinois halving on the step's cubic
Hermite interpolant, then a secant on RK4 steps) and restarts from there.
"""

from __future__ import annotations

import numpy as np

from abb_ros.model.dynamics.kernels.layout import (
    CACHE_DERIV,
    CACHE_STATE,
    CACHE_TAG,
    S_MODE,
    SPINDLE_RAMP,
    kernel,
)
from abb_ros.model.dynamics.kernels.rk4 import rk4_after_k1
from abb_ros.model.dynamics.kernels.rolling_resistance import rolling_deriv

MAX_SWITCHES = 16
"""Most rolling-regime switches located within one RK4 (sub)step (the rest of the step then
keeps the regimes it has)."""
SWITCH_TOL = 1.0e-12
"""A switching instant is located to this fraction of the (sub)step at worst ..."""
MARGIN_TOL = 1.0e-9
"""... or to a state past it whose switching function (dimensionless) is above -MARGIN_TOL
(the band's margin changes at ~1 / STICK_TIME: ~1e-12 s)."""
MAX_LOCATE = 60
"""Most regula-falsi iterations per switching instant."""


@kernel
def hermite(s, H, y0, f0, y1, f1, out):
    """Set out to the cubic Hermite interpolant at s H (0 <= s <= 1) of a step of H.

    The step goes from (y0, f0) to (y1, f1) (values and derivatives).
    """
    s2 = s * s
    s3 = s2 * s
    a0 = 2.0 * s3 - 3.0 * s2 + 1.0
    b0 = (s3 - 2.0 * s2 + s) * H
    a1 = 3.0 * s2 - 2.0 * s3
    b1 = (s3 - s2) * H
    for i in range(y0.shape[0]):
        out[i] = a0 * y0[i] + b0 * f0[i] + a1 * y1[i] + b1 * f1[i]


@kernel
def illinois(lo, glo, hi, ghi, side, tau, gt):
    """Return the bracket [lo, hi] of a root updated with (tau, gt), and the next estimate.

    Margins glo >= 0 > ghi; regula falsi with the Illinois halving, bisection where it
    would leave the bracket. Returns (lo, glo, hi, ghi, side, estimate).
    """
    if gt >= 0.0:
        lo, glo = tau, gt
        if side == 1:
            ghi *= 0.5
        side = 1
    else:
        hi, ghi = tau, gt
        if side == -1:
            glo *= 0.5
        side = -1
    est = hi - ghi * (hi - lo) / (ghi - glo)
    if not lo < est < hi:
        est = 0.5 * (lo + hi)
    return lo, glo, hi, ghi, side, est


@kernel
def rolling_cache_hit(y, n, S, cache):
    """Return True when ``cache`` holds the regimes and derivative of the state y.

    ``cache`` of :func:`rolling_substep`, under the spindle profile S (a ramp's
    time-dependent theta'' never hits).
    """
    if cache[CACHE_TAG, 0] != 1.0 or S[S_MODE] == SPINDLE_RAMP:
        return False
    for i in range(y.shape[0]):
        if cache[CACHE_STATE, i] != y[i]:
            return False
    for i in range(S.shape[0]):
        if cache[CACHE_TAG, 1 + n + i] != S[i]:
            return False
    return True


@kernel
def rolling_substep(t, h, y, n, P, S, stages, solver, events, cache):
    """Take one RK4 step of h from (t, y) under rolling resistance, y in place.

    Its regime switches are located; returns their number.

    The balls' regimes at the start
    (:func:`abb_ros.model.dynamics.kernels.rolling_resistance.accel_rolling`) are kept over the
    step (each law's smooth extension, so RK4 keeps its order). Where the regimes of the end state
    differ and the switching function there is negative, a regime ended inside the step: its
    instant is located by regula falsi (Illinois) on the RK4 step from the start, to SWITCH_TOL
    h; the step is taken to just past it, the regimes of that state determined, and the rest of
    the step integrated the same way (at most MAX_SWITCHES switches). The step's end stays t +
    h. Row k of ``events`` receives switch k: [its offset from t, the regimes after it (n), the
    state there (2N)]. ``cache`` (3, 2N) carries the end state, its derivative and [1, regimes
    (n), S] to the next step's start (rows CACHE_*, :func:`rolling_cache_hit`; zeros: none).
    """
    k1, k3, k4, yt = stages.k1, stages.k3, stages.k4, stages.yt
    n2 = y.shape[0]
    y0 = y.copy()
    mode = np.empty(n)
    after = np.empty(n)
    if rolling_cache_hit(y0, n, S, cache):
        for i in range(n2):
            k1[i] = cache[CACHE_DERIV, i]
        for b in range(n):
            mode[b] = cache[CACHE_TAG, 1 + b]
    else:
        rolling_deriv(t, y0, n, P, S, mode, False, k1, solver)
    start = 0.0
    switches = 0
    locate = True
    while True:
        rk4_after_k1(t + start, h - start, y0, y, n, P, S, mode, stages, solver)
        # the end state's regimes and derivative: the next step's start
        rolling_deriv(t + h, y, n, P, S, after, False, cache[CACHE_DERIV], solver)
        for i in range(n2):
            cache[CACHE_STATE, i] = y[i]
        cache[CACHE_TAG, 0] = 1.0
        for b in range(n):
            cache[CACHE_TAG, 1 + b] = after[b]
        for i in range(S.shape[0]):
            cache[CACHE_TAG, 1 + n + i] = S[i]
        changed = False
        for b in range(n):
            if after[b] != mode[b]:
                changed = True
        if not changed or not locate or switches == MAX_SWITCHES:
            return switches
        H = h - start
        ghi = rolling_deriv(t + h, y, n, P, S, mode, True, k4, solver)
        glo = rolling_deriv(t + start, y0, n, P, S, mode, True, yt, solver)
        if ghi >= 0.0 or glo < 0.0:
            return switches                 # no crossing of this regime's boundary
        # 1. the crossing on the step's cubic Hermite interpolant (one solve per iterate)
        lo, g_lo, hi, g_hi, side = 0.0, glo, H, ghi, 0
        tau = H * glo / (glo - ghi)
        for _ in range(MAX_LOCATE):
            hermite(tau / H, H, y0, k1, y, k4, yt)
            gt = rolling_deriv(t + start + tau, yt, n, P, S, mode, True, k3, solver)
            if abs(gt) <= 1e-3 * MARGIN_TOL:    # (a ball that has just switched has a
                break                           # margin of ~MARGIN_TOL: not a crossing)
            lo, g_lo, hi, g_hi, side, tau = illinois(lo, g_lo, hi, g_hi, side, tau, gt)
            if hi - lo <= SWITCH_TOL * h:
                break
        # 2. secant on RK4 steps from the segment start, from there (the interpolant's local
        # slope first), aimed at the margin -MARGIN_TOL / 2 just past the crossing, until one
        # lands in (-MARGIN_TOL, 0)
        slope = (g_hi - g_lo) / (hi - lo) if hi > lo else 0.0
        if not slope < 0.0:
            slope = (ghi - glo) / H         # the step's secant (ghi < 0 <= glo)
        lo, hi = 0.0, H
        at_hi = False
        t_prev, g_prev = tau, 0.0
        for k in range(MAX_LOCATE):
            rk4_after_k1(t + start, tau, y0, y, n, P, S, mode, stages, solver)
            gt = rolling_deriv(t + start + tau, y, n, P, S, mode, True, yt, solver)
            at_hi = gt < 0.0
            if at_hi:
                hi = tau
            else:
                lo = tau
            if (at_hi and gt > -MARGIN_TOL) or hi - lo <= SWITCH_TOL * h:
                break
            if k > 0 and tau != t_prev and (gt - g_prev) / (tau - t_prev) < 0.0:
                slope = (gt - g_prev) / (tau - t_prev)
            t_prev, g_prev = tau, gt
            tau -= (gt + 0.5 * MARGIN_TOL) / slope
            if not lo < tau < hi:
                tau = 0.5 * (lo + hi)
        if not at_hi:
            rk4_after_k1(t + start, hi, y0, y, n, P, S, mode, stages, solver)
        start += hi
        for i in range(n2):
            y0[i] = y[i]
        rolling_deriv(t + start, y0, n, P, S, after, False, k1, solver)
        changed = False
        for b in range(n):
            if after[b] != mode[b]:
                changed = True
            mode[b] = after[b]
        if changed:
            events[switches, 0] = start
            for b in range(n):
                events[switches, 1 + b] = mode[b]
            for i in range(n2):
                events[switches, 1 + n + i] = y0[i]
            switches += 1
        else:
            locate = False      # the state past the crossing keeps its regimes: finish with them

"""The usual hardware-in-the-loop measures of a run, on plain arrays (a lockstep Trace's).

Settling time, peak rbar, ball angles against the balanced equilibrium phi* (Eq. 26) and the
time spent inside the unbalanced speed bands (speed_bands.unbalanced_bands). Each measure is a
function returning a number; ``assert_*`` wrap the ones a test usually bounds, with a message
that states the measured value.
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics.state import wrap_angle
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.stability.equilibrium import balanced_equilibrium

__all__ = ['settling_time', 'peak', 'phi_star_error_deg', 'time_in_bands',
           'assert_balls_at_phi_star', 'assert_settles']


def settling_time(t, x, final: float, tol: float) -> float:
    """Return the first time [s] from which |x - final| <= tol for every later sample.

    inf when the last sample is still outside, t[0] when none ever is.
    """
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    outside = np.flatnonzero(~(np.abs(x - final) <= tol))
    if outside.size == 0:
        return float(t[0])
    k = outside[-1] + 1
    return float(t[k]) if k < t.size else math.inf


def peak(t, x, t_from: float = -math.inf, t_to: float = math.inf) -> float:
    """Return the largest x over t_from <= t <= t_to (e.g. peak rbar during the run-up)."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    window = x[(t >= t_from) & (t <= t_to)]
    return float(np.max(window)) if window.size else math.nan


def phi_star_error_deg(phi, drive: DriveParams) -> float:
    """Return the largest angle [deg] between a ball and its place in phi* (Eq. 26).

    Balls are matched to the balanced equilibrium phi* in angular order (any ball may take
    any place). inf when the drive has no balanced equilibrium.
    """
    eq = balanced_equilibrium(drive)
    if not eq.exists:
        return math.inf
    phi = np.sort(wrap_angle(np.asarray(phi, dtype=float)))
    star = np.sort(wrap_angle(eq.phi_star))
    n = phi.size
    # Every cyclic assignment of the sorted balls to the sorted places; the best one.
    return min(float(np.max(np.abs(np.degrees(wrap_angle(np.roll(phi, k) - star)))))
               for k in range(max(n, 1)))


def time_in_bands(t, omega, bands) -> float:
    """Return the time [s] with the speed inside an unbalanced band.

    Each sample counts for the interval to the next one.
    """
    t, omega = np.asarray(t, dtype=float), np.asarray(omega, dtype=float)
    if t.size < 2:
        return 0.0
    inside = np.zeros(t.size, dtype=bool)
    for b in bands:
        inside |= (omega >= b.lo) & (omega <= b.hi)
    return float(np.sum(np.diff(t)[inside[:-1]]))


def assert_balls_at_phi_star(phi, drive: DriveParams, tol_deg: float) -> float:
    """Assert that every ball is within ``tol_deg`` of +-phi*; return the largest error [deg]."""
    err = phi_star_error_deg(phi, drive)
    star = balanced_equilibrium(drive).phi_star
    balls = np.degrees(wrap_angle(np.asarray(phi))).round(3).tolist()
    assert err <= tol_deg, (f'balls at {balls} '
                            f'deg are {err:.3f} deg from phi* = '
                            f'{np.degrees(star).round(3).tolist()} deg (allowed {tol_deg:g})')
    return err


def assert_settles(t, x, final: float, tol: float, by: float) -> float:
    """Assert that x settles within tol of final by time ``by`` [s]; return the settling time."""
    ts = settling_time(t, x, final, tol)
    assert ts <= by, f'settles (|x - {final:g}| <= {tol:g}) at t = {ts:.4f} s, later than {by:g} s'
    return ts

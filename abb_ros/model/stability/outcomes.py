"""Where a run from one start ended: balanced, or which unbalanced state, in named classes.

A basin study (docs/basin.md) runs the nonlinear model from many initial ball positions and
asks of each run whether the balls found their place. The answer is read from the last part
of the run, the *rest window* (the last :data:`REST_WINDOW` of the duration, at least
:data:`REST_WINDOW_MIN` s), sampled at the publish rate:

- the balls are **at rest** when no ball angle (relative to the rotor, unwrapped) moves by
  more than ``rest_tol_deg`` within the window;
- **balanced**: at rest, final rbar <= ``rbar_limit``, and the final angles near an
  equilibrium of Eq. (26): the Eq. (26) residual (``equilibrium.eq26_residual``, the
  imbalance left over in units of one ball's m R) at most :data:`EQ26_NEAR`; with two races
  both the force and the couple left over (``two_plane.balance_residual``);
- **settling**: at rest near an Eq. (26) equilibrium, but rbar still above the limit;
- **packed**: at rest, not balanced, all balls side by side in one chain (for point masses
  merged within :data:`PACK_TOL_DEG`; for balls with contact each within the contact
  separation plus that), the locked state below the first resonance (Section 5, P1) or the
  packed chain at an imbalance beyond the balls' capacity;
- **friction_rest**: at rest elsewhere with rolling resistance on: held by it short of an
  equilibrium (the "plug and pray" rest states);
- **unbalanced_rest**: at rest elsewhere without rolling resistance;
- **drifting**: not at rest, and some ball laps the rotor within the rest window (turns a full
  revolution or more relative to it): a non-synchronous state, which two races can settle
  into (docs/equations.md, F7), never a balanced one;
- **moving**: not at rest at the end otherwise (still travelling, or oscillating as in an
  unbalanced speed band);
- **failed**: the state left the model's envelope or became non-finite (StateError).

The classes are exclusive and checked in that order (failed first).
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics.state import StateLayout
from abb_ros.model.stability.equilibrium import eq26_residual
from abb_ros.model.stability.two_plane import balance_residual

__all__ = ['CLASSES', 'EQ26_NEAR', 'PACK_TOL_DEG', 'REST_WINDOW', 'REST_WINDOW_MIN',
           'REST_TOL_DEG', 'classify', 'rest_window', 'packed']

CLASSES = ('balanced', 'settling', 'packed', 'friction_rest', 'unbalanced_rest', 'drifting',
           'moving', 'failed')
"""Outcome classes, in the order they are checked (after 'failed')."""

EQ26_NEAR = 0.05
"""Largest Eq. (26) residual (imbalance left, in units of one ball's m R) of a balanced end.
At P3 (M eps / (m R) = 0.556) it means the balls cancel at least 91 % of the disc's
imbalance; steel balls stopped by rolling resistance at this residual leave rbar of about
5e-4 (docs/basin.md), half the default rbar limit."""

PACK_TOL_DEG = 1.0
"""Balls within this angle [deg] (beyond the contact separation with contact) touch or merge."""

REST_WINDOW = 0.1
"""Fraction of the run at its end in which the balls must stay put to be at rest."""

REST_WINDOW_MIN = 0.05
"""Shortest rest window [s] (several revolutions at any speed of interest)."""

REST_TOL_DEG = 0.5
"""Default largest motion [deg] of any ball within the rest window of balls at rest."""


def rest_window(t: np.ndarray) -> np.ndarray:
    """Return the indices of the samples at times t [s] that form the rest window."""
    t = np.asarray(t, dtype=float)
    span = max(REST_WINDOW * (t[-1] - t[0]), REST_WINDOW_MIN)
    return np.nonzero(t >= t[-1] - span - 1e-12)[0]


def packed(phi, separation: float) -> bool:
    """Return whether the ball angles phi [rad] form one chain of touching (or merged) balls.

    ``separation``: the contact separation [rad] (0 for point masses). The balls are packed when
    every gap but the largest around the race is at most separation + PACK_TOL_DEG.
    """
    phi = np.sort(np.mod(np.asarray(phi, dtype=float), 2 * math.pi))
    if phi.size < 2:
        return False
    gaps = np.diff(np.concatenate([phi, phi[:1] + 2 * math.pi]))
    gaps = np.sort(gaps)[:-1]
    return bool(np.all(gaps <= separation + math.radians(PACK_TOL_DEG)))


def classify(params, t, ys, rbar_limit: float, rest_tol_deg: float = REST_TOL_DEG
             ) -> tuple[str, float, float]:
    """Return (class, eq26 residual, motion [deg]) of a complete run's samples.

    t [s] shape (T,), ys the states, shape (T, 2N); a run that failed is class 'failed'
    without samples to classify (:mod:`abb_ros.basin.compute`).
    """
    layout = StateLayout.of(params.n_balls)
    phi = layout.phi(ys)
    window = rest_window(t)
    unwrapped = np.unwrap(phi[window], axis=0)
    motion = float(np.degrees((unwrapped.max(axis=0) - unwrapped.min(axis=0)).max(initial=0.0)))
    final = phi[-1]
    residual = float(balance_residual(params, final) if params.race2_n
                     else eq26_residual(params, final))
    if motion > rest_tol_deg:
        laps = np.abs(unwrapped[-1] - unwrapped[0]).max(initial=0.0) / (2 * math.pi)
        return ('drifting' if laps >= 1.0 else 'moving'), residual, motion
    if residual <= EQ26_NEAR:
        rbar = float(layout.rbar(ys[-1], params.R))
        return ('balanced' if rbar <= rbar_limit else 'settling'), residual, motion
    separation = params.contact_separation if params.contact_E > 0 else 0.0
    if packed(final, separation):
        return 'packed', residual, motion
    if params.rolling_mu > 0:
        return 'friction_rest', residual, motion
    return 'unbalanced_rest', residual, motion

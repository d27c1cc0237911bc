"""The numbers of a basin study: P(balance) with its Wilson interval, the classes, Floquet.

The balanced fraction is k / N over the starts that were run (``overlap`` starts left out),
with the 95 % Wilson score interval (:func:`abb_ros.sweep.proportions.wilson`). Beside it, the
local verdict: the Floquet multipliers of the balanced equilibrium (symmetric fan, Eq. 26; for
n >= 3 transverse to the family) at the operating speed,
:func:`abb_ros.model.stability.floquet.point_stability`.
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.basin.compute import OVERLAP
from abb_ros.model.stability.outcomes import CLASSES
from abb_ros.sweep.proportions import wilson

__all__ = ['operating_omega', 'floquet_verdict', 'fraction_summary']


def operating_omega(scenario, omega_final=None):
    """Return the operating speed [rad/s] of the scenario and where it comes from.

    The last speed command (or the constant speed); for a spindle driven by torque, the median
    final speed of the runs ``omega_final`` (None when there is none).
    """
    from abb_ros.model.dynamics.spindle import TorqueMotor
    if isinstance(scenario.spindle, TorqueMotor):
        good = np.asarray(omega_final if omega_final is not None else [], dtype=float)
        good = good[np.isfinite(good)]
        if good.size == 0:
            return None, 'torque mode: no completed run'
        return float(np.median(good)), 'torque mode: median final speed of the runs'
    if scenario.commands:
        return float(scenario.commands[-1].omega), 'last speed command'
    return float(scenario.omega), 'constant speed'


def floquet_verdict(params, omega) -> dict:
    """Return the Floquet verdict at ``omega`` [rad/s] as a JSON-able mapping.

    ``lam_max`` is over one spindle period; ``coupled``: a drive with heights or a leaning
    axis, whose one coupled value fills ``lam_in`` and ``lam_out`` as well; ``transverse``:
    the multipliers are taken transverse to a family of balanced states (n >= 3 in one race;
    two races where the balls outnumber both planes' four conditions).
    """
    from abb_ros.model.stability.floquet import point_stability
    if omega is None:
        return {'balanced': None}
    st = point_stability(params, omega)
    return {'balanced': bool(st.balanced), 'verdict': st.verdict, 'omega_rad_s': omega,
            'wbar': omega / params.omega0, 'lam_in': _finite(st.lam_in),
            'lam_out': _finite(st.lam_out), 'lam_max': _finite(st.lam_max),
            'coupled': st.coupled, 'neutral_modes_removed': int(st.neutral),
            'phi_star_deg': [round(float(a), 6) for a in np.degrees(st.phi_star)],
            'transverse': int(st.neutral) > 0}


def _finite(x: float):
    return float(x) if math.isfinite(x) else None


def fraction_summary(outcomes) -> dict:
    """Return runs, balanced count and fraction, ci95 and the class counts of ``outcomes``."""
    outcomes = np.asarray(outcomes, dtype=object)
    run = outcomes[outcomes != OVERLAP]
    k = int((run == 'balanced').sum())
    n = int(run.size)
    lo, hi = wilson(k, n)
    counts = {c: int((outcomes == c).sum()) for c in CLASSES + (OVERLAP,)}
    return {'runs': n, 'balanced': k, 'balanced_fraction': k / n if n else None,
            'ci95': [lo, hi] if n else None, 'outcomes': counts}

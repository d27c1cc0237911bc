"""Step sizes that resolve a ball-ball contact, and when a step must be taken again.

While two balls touch, their Hertz contact (:mod:`abb_ros.model.dynamics.kernels.contact`) is far
stiffer than the rest of the drive: a step is split into sub-steps that keep omega_c h of the
stiffest contact below CONTACT_OMEGA_H (impacts, :func:`impact_relaxation` for slow ones) or
CONTACT_OMEGA_H_REST (resting contacts, :func:`contact_regimes`); a step whose resting
contact did not rest is taken again as an impact (:func:`retake_substeps`).
"""

from __future__ import annotations

import math

from abb_ros.model.dynamics.kernels.contact import contact_scales, near, pair_state
from abb_ros.model.dynamics.kernels.layout import P_CONTACT_DAMPING, kernel
from abb_ros.model.dynamics.state import PHI

CONTACT_OMEGA_H = 0.3
"""Largest omega_c h of the stiffest contact per RK4 (sub)step during an impact."""
CONTACT_IMPACT_SPEED = 0.128
"""Impacts slower than this [m/s] are resolved to an absolute rather than a relative accuracy
(:func:`impact_relaxation`): at CONTACT_OMEGA_H / MIS_IMPACT_REFINE RK4 returns a Hertz
impact's rebound speed to 7.8e-5 of it at worst (measured over the phases of the contact's
onset on the sub-step grid), i.e. to 1e-5 m/s at this speed."""
CONTACT_ERROR_ORDER = 2.7
"""That rebound error grows as (omega_c h)^2.7 (measured from omega_c h = 0.1 to 0.8: the
onset of a Hertz contact is not smooth, so RK4 is not of order 4 there)."""
CONTACT_RELAX_MAX = 3.0
"""A slow impact's omega_c h is at most this many times an impact's (where the error law was
measured)."""
CONTACT_OMEGA_H_REST = 2.0
"""Largest omega_c h of a resting contact (its present overlap exceeds the impact overlap of
its approach speed): below RK4's stability limit 2.78, its unresolved contact vibration is
damped numerically, the static compression is exact."""
CONTACT_REST_IMBALANCE = 0.25
"""A pair taken for resting did not rest over a step when its rate changed by more than this
fraction of what its contact force alone, unbalanced, would change it by over the step
(:func:`resting_misjudged`): a resting contact's force is carried by the load that presses the
balls together (~0), an impact's by nothing (~1)."""
MAX_SUBSTEPS = 4096
"""Most sub-steps of one step."""
MIS_IMPACT_REFINE = 1.5
"""The multirate step's fast sub-steps per contact sub-step in an impact (rounded up): the
impact's resolution is its largest error (energy closure of a collision without rolling
resistance: 1.0e-6 with 1, 5.3e-7 with 1.5, 5.2e-7 with 2, 3.9e-7 with 4; RK4 sub-steps of
the whole system: 1.5e-7, docs/ball_size_contact_rolling.md)."""


@kernel
def contact_substeps(y, n, P, dt):
    """Return the RK4 sub-steps per step of dt that resolve every contact.

    They keep omega_c h <= CONTACT_OMEGA_H (impacts) or CONTACT_OMEGA_H_REST (resting contacts)
    for every pair of balls that can touch within the step. omega_c = sqrt(4 k_c / m_b) bounds
    a chain of balls, with k_c = 1.5 K sqrt(delta_peak), delta_peak the Hertz peak overlap for
    the present overlap and approach speed; plus the contact damping rate.
    """
    return contact_regime(y, n, P, dt)[0]


@kernel
def contact_regime(y, n, P, dt):
    """Return (:func:`contact_substeps`, impact) of the step of dt from y.

    ``impact`` is True when a pair that can touch within the step has more kinetic than static
    overlap (an impact, not a resting contact).
    """
    return contact_regime_as(y, n, P, dt, False)


@kernel
def contact_regime_as(y, n, P, dt, every_impact):
    """Return :func:`contact_regime`, every contact an impact if ``every_impact``.

    Every pair that can touch within the step is resolved as an impact when
    ``every_impact`` (a step retaken after :func:`resting_misjudged`).
    """
    k, impact, resting = contact_regimes(y, n, P, dt, every_impact)
    return k, impact


@kernel
def contact_regimes(y, n, P, dt, every_impact):
    """Return (:func:`contact_regime_as`, resting) of the step of dt from y.

    ``resting`` is True when a pair was resolved as a resting contact (the step may have to be
    taken again, :func:`retake_substeps`).
    """
    K, mb, sep = contact_scales(P)
    chi = P[P_CONTACT_DAMPING]
    N = PHI + n
    need = 0.0
    impact = False
    resting = False
    for i in range(n):
        for j in range(i + 1, n):
            reach = sep + 2.0 * abs(y[N + PHI + j] - y[N + PHI + i]) * dt
            if not near(y[PHI + j] - y[PHI + i], reach):
                continue
            delta, rate, lever = pair_state(y, n, P, i, j)
            if delta + 2.0 * max(rate, 0.0) * dt <= 0.0:
                continue
            static, kinetic = pair_energies(delta, rate, K, mb)
            peak = (static + kinetic) ** 0.4
            if peak <= 0.0:
                continue
            kc = 1.5 * K * math.sqrt(peak)
            w = math.sqrt(4.0 * kc / mb) + 2.0 * chi * K * peak * math.sqrt(peak) / mb
            if kinetic > static or every_impact:
                impact = True
                w /= CONTACT_OMEGA_H * impact_relaxation(static + kinetic, K, mb)
            else:
                resting = True
                w /= CONTACT_OMEGA_H_REST
            if w > need:
                need = w
    k = int(math.ceil(need * dt))
    if k < 1:
        k = 1
    if k > MAX_SUBSTEPS:
        k = MAX_SUBSTEPS
    return k, impact, resting


@kernel
def pair_energies(delta, rate, K, mb):
    """Return the (static, kinetic) overlap 'energies' of a pair, in delta^2.5.

    At overlap delta and its rate: the present overlap's, max(delta, 0)^2.5, and the Hertz peak
    overlap's of the rate, 5/8 m_b rate^2 / K (:func:`contact_regime_as`). More kinetic than
    static: an impact, else a resting contact.
    """
    d0 = max(delta, 0.0)
    return d0 * d0 * math.sqrt(d0), 0.625 * mb * rate * rate / K


@kernel
def impact_relaxation(energy, K, mb):
    """Return how many times longer than an impact's sub-steps a slow impact's may be.

    The factor (>= 1) on CONTACT_OMEGA_H / omega_c: the impact's speed v (from its peak
    overlap's ``energy`` = delta_peak^2.5, as in :func:`contact_regime`) below
    CONTACT_IMPACT_SPEED keeps the rebound speed's error (relative error x v) at what the
    impact at that speed has, (CONTACT_IMPACT_SPEED / v) ^ (1 / CONTACT_ERROR_ORDER), at most
    CONTACT_RELAX_MAX.
    """
    v = math.sqrt(energy * K / (0.625 * mb))
    if v * CONTACT_RELAX_MAX ** CONTACT_ERROR_ORDER <= CONTACT_IMPACT_SPEED:
        return CONTACT_RELAX_MAX
    if v >= CONTACT_IMPACT_SPEED:
        return 1.0
    return (CONTACT_IMPACT_SPEED / v) ** (1.0 / CONTACT_ERROR_ORDER)


@kernel
def resting_misjudged(y0, y1, n, P, dt):
    """Return True when a contact taken for resting did not rest over the step.

    A pair of balls that :func:`contact_regime` took for a resting contact at y0
    (touching, its overlap's energy at least its rate's) did not rest over the step of dt to
    y1: its overlap there is under half or over twice that at y0, its rate's energy exceeds its
    overlap's, or its force was not carried: its rate changed by more than
    CONTACT_REST_IMBALANCE of 2 K delta^1.5 dt / m_b, what the contact force at y0 alone would
    change it by. From the state alone an impact caught near its peak looks like a resting
    contact; resolved as one (CONTACT_OMEGA_H_REST), its rebound would be wrong by up to a few
    % of the impact's speed (the step across the peak changes neither the overlap nor the
    energies much, but it turns the rate round).
    """
    K, mb, sep = contact_scales(P)
    for i in range(n):
        for j in range(i + 1, n):
            if not near(y0[PHI + j] - y0[PHI + i], sep):
                continue
            delta, rate, lever = pair_state(y0, n, P, i, j)
            static, kinetic = pair_energies(delta, rate, K, mb)
            if delta <= 0.0 or kinetic > static:
                continue                        # apart, or an impact (resolved as one)
            d1, r1, lever = pair_state(y1, n, P, i, j)
            if d1 < 0.5 * delta or d1 > 2.0 * delta:
                return True
            if abs(r1 - rate) * mb > CONTACT_REST_IMBALANCE * 2.0 * K * static / delta * dt:
                return True                     # (K delta^1.5 = K static / delta)
            static, kinetic = pair_energies(d1, r1, K, mb)
            if kinetic > static:
                return True
    return False


@kernel
def retake_substeps(start, y, n, P, dt, impact, used, refine):
    """Return the sub-steps to take a step again with, or 0 to keep it.

    The sub-steps to take the step of dt from ``start`` (which gave y in ``used`` sub-steps) again
    with every contact resolved as an impact (:func:`contact_regime_as`, times ``refine``), or
    0: only a step resolved as resting (not ``impact``) whose resting contact did not rest
    (:func:`resting_misjudged`) and when an impact needs more sub-steps than ``used`` (a step
    that an impact would take whole is not taken again).
    """
    if impact or not resting_misjudged(start, y, n, P, dt):
        return 0
    forced = contact_regime_as(start, n, P, dt, True)[0]
    return int(math.ceil(forced * refine)) if forced > used else 0


@kernel
def mis_substeps(y, n, P, dt):
    """Return the fast RK4 sub-steps of the multirate step of dt from y.

    The sub-steps of :func:`abb_ros.model.dynamics.kernels.multirate.mis_contact_step`:
    :func:`contact_substeps`, times MIS_IMPACT_REFINE in an impact (:func:`contact_regime`).
    """
    sub, impact = contact_regime(y, n, P, dt)
    return int(math.ceil(sub * MIS_IMPACT_REFINE)) if impact else sub

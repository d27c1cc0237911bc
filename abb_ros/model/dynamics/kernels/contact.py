"""Ball-ball contact: the Hunt-Crossley (Hertz) force between two balls on the race.

Two balls i < j of radius r on the race radius R have centres 2 R |sin(dphi/2)| apart; where
they overlap by delta > 0 the force F = K delta^1.5 (1 + chi delta') >= 0 acts along the line
of centres (potential 2/5 K delta^2.5, dissipation 1/2 chi K delta^1.5 delta'^2). Its
generalized forces Qc load the ball rows of Eq. (24) (added in
:func:`abb_ros.model.dynamics.kernels.eom.assemble`); they are internal, so no force acts on the
deck or the rotor. Switched on by ``contact_E`` (docs/ball_size_contact_rolling.md).
"""

from __future__ import annotations

import math

from abb_ros.model.dynamics.kernels.ball_size import SPIN_INERTIA
from abb_ros.model.dynamics.kernels.layout import (
    P_BALL_ROTATION,
    P_CONTACT_DAMPING,
    P_CONTACT_E,
    P_CONTACT_NU,
    P_R,
    P_R_BALL,
    P_m,
    kernel,
)
from abb_ros.model.dynamics.state import PHI


@kernel
def contact_stiffness(P):
    """Return K of the Hertzian law F = K delta^1.5 between two equal balls [N/m^1.5].

    K = 4/3 E* sqrt(r/2), E* = E / (2 (1 - nu^2)).
    """
    r, E, nu = P[P_R_BALL], P[P_CONTACT_E], P[P_CONTACT_NU]
    return 4.0 / 3.0 * E / (2.0 * (1.0 - nu * nu)) * math.sqrt(0.5 * r)


@kernel
def contact_scales(P):
    """Return (K, a ball's mass m_b, the angle at which two balls touch).

    K of :func:`contact_stiffness`; m_b is 7/5 m for rolling balls; the angle is
    2 asin(r / R).
    """
    mb = P[P_m] * (1.0 + SPIN_INERTIA * P[P_BALL_ROTATION])
    return contact_stiffness(P), mb, 2.0 * math.asin(P[P_R_BALL] / P[P_R])


@kernel
def near(dphi, reach):
    """Return True when the angle dphi, wrapped to [-pi, pi), is shorter than reach.

    A cheap test before :func:`pair_state`.
    """
    dphi -= 2.0 * math.pi * math.floor(dphi / (2.0 * math.pi) + 0.5)
    return abs(dphi) < reach


@kernel
def pair_state(y, n, P, i, j):
    """Return (overlap delta, its rate delta', lever) of balls i < j.

    Their centres are 2 R |sin(dphi/2)| apart (dphi = phi_j - phi_i wrapped to [-pi, pi));
    delta = 2 r - distance; lever = d distance / d phi_j = R cos(dphi/2) sign(dphi) =
    -d distance / d phi_i.
    """
    N = PHI + n
    R, r = P[P_R], P[P_R_BALL]
    dphi = y[PHI + j] - y[PHI + i]
    dphi -= 2.0 * math.pi * math.floor(dphi / (2.0 * math.pi) + 0.5)
    half = 0.5 * dphi
    lever = R * math.cos(half)
    if dphi < 0.0:
        lever = -lever
    delta = 2.0 * r - 2.0 * R * abs(math.sin(half))
    rate = -lever * (y[N + PHI + j] - y[N + PHI + i])
    return delta, rate, lever


@kernel
def hertz_force(K, chi, delta, rate):
    """Return (force, its elastic part) of F = K delta^1.5 (1 + chi delta') >= 0, delta > 0."""
    elastic = K * delta * math.sqrt(delta)
    force = elastic * (1.0 + chi * rate)
    if force < 0.0:
        force = 0.0
    return force, elastic


@kernel
def contact_forces(y, n, P, Qc):
    """Fill Qc (one per ball row) with the contact forces; return (energy, damping power).

    On ball j Q_j = F lever, on ball i the opposite. Returns the contact potential energy
    [J] and the contact damping power [W].
    """
    K = contact_stiffness(P)
    chi = P[P_CONTACT_DAMPING]
    sep = 2.0 * math.asin(P[P_R_BALL] / P[P_R])
    for i in range(n):
        Qc[i] = 0.0
    energy = 0.0
    power = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            e, p = add_pair_force(y, n, P, K, chi, sep, i, j, Qc)
            energy += e
            power += p
    return energy, -power


@kernel
def add_pair_force(y, n, P, K, chi, sep, i, j, Qc):
    """Add the force of the pair (i, j) to Qc; return its (energy, elastic minus total power)."""
    if not near(y[PHI + j] - y[PHI + i], sep):
        return 0.0, 0.0
    delta, rate, lever = pair_state(y, n, P, i, j)
    if delta <= 0.0:
        return 0.0, 0.0
    force, elastic = hertz_force(K, chi, delta, rate)
    Qc[j] += force * lever
    Qc[i] -= force * lever
    return 0.4 * elastic * delta, (elastic - force) * rate

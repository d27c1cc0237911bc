"""Balls of finite size that roll on the race: their spin inertia J_b = 2/5 m r^2.

A ball rolling on the race (contact at radius R + r) spins at Omega = theta' + gamma' +
alpha' beta - (R / r) phi_i' about z, plus the deck's alpha', beta'. Its kinetic energy
1/2 J_b |omega|^2, first order in the deck, amends the rows of Eqs. (21)-(24) that
:func:`abb_ros.model.dynamics.kernels.eom.assemble` builds (switched on by ``ball_rotation``).
"""

from __future__ import annotations

from abb_ros.model.dynamics.kernels.layout import P_BALL_ROTATION, P_R, P_R_BALL, P_m, kernel
from abb_ros.model.dynamics.state import PHI

SPIN_INERTIA = 0.4
"""J_b = 2/5 m r_ball^2 of a solid sphere."""


@kernel
def add_ball_rotation(y, n, P, thdd, A, W, f, B, fb):
    """Add the rolling balls' spin inertia to the assembled rows, in place.

    J_b (R/r)^2 = 2/5 m R^2 adds to the ball row's phi_i'' (7/5 in all), J_b R/r = 2/5 m R r
    to the gamma'' and theta'' couplings, J_b to the deck's rotational inertias, and the spin
    terms J_b Omega beta', -J_b Omega alpha' (like J_z) to the alpha and beta rows.
    """
    N = PHI + n
    R, m, r = P[P_R], P[P_m], P[P_R_BALL]
    Jb = SPIN_INERTIA * m * r * r
    JbRr = SPIN_INERTIA * m * R * r          # J_b R / r
    be = y[5]
    ald, bed = y[N + 4], y[N + 5]
    om = y[N]
    spin = 0.0                               # sum J_b (theta' - R/r phi_i')
    for i in range(n):
        spin += Jb * om - JbRr * y[N + PHI + i]
        W[3, i] -= JbRr * be
        W[5, i] -= JbRr
        B[i, 5] -= JbRr
        fb[i] += JbRr * thdd
    A[3, 3] += n * Jb
    A[4, 4] += n * Jb
    A[5, 5] += n * Jb
    f[3] -= n * Jb * thdd * be + spin * bed
    f[4] += spin * ald
    f[5] -= n * Jb * thdd


@kernel
def ball_inertia(P):
    """Return m R^2 of a ball's row, times 7/5 for rolling balls (J_b (R/r)^2 = 2/5 m R^2)."""
    mR2 = P[P_m] * P[P_R] * P[P_R]
    if P[P_BALL_ROTATION] != 0.0:
        mR2 += SPIN_INERTIA * mR2
    return mR2


@kernel
def spin_coupling(P):
    """Return J_b R / r = 2/5 m R r of rolling balls (0 when their rotation is off)."""
    if P[P_BALL_ROTATION] != 0.0:
        return SPIN_INERTIA * P[P_m] * P[P_R] * P[P_R_BALL]
    return 0.0

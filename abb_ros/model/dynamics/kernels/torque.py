"""Torque mode: theta a degree of freedom, driven by the spindle motor's torque.

The free-theta row of Lagrange's equations (docs/torque_mode.md; theta's row alongside Eqs.
18-24), to first order in the deck, is solved together with the deck and ball rows of
:func:`abb_ros.model.dynamics.kernels.eom.assemble` (:func:`accel_free_theta`).
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics.kernels.eom import assemble, eliminate_balls, solve_deck
from abb_ros.model.dynamics.kernels.layout import P_EPS, P_M, P_R, P_J_z, P_m, kernel
from abb_ros.model.dynamics.kernels.spindle import spindle_torque
from abb_ros.model.dynamics.state import DECK, PHI, THETA


@kernel
def theta_row(y, n, P, a, col):
    """Fill the free-theta equation's coefficients; return that of theta''.

    The equation, to first order in the deck coordinates (docs/torque_mode.md):

        (J_z + I_r)(theta'' + gamma'') - S1 X'' + C1 Y'' + m R^2 sum phi_i'' = Q_theta,

    I_r = M eps^2 + n m R^2, S1, C1 = sum mu r (sin, cos) psi over G and the balls. Fills
    ``a`` (6) with its deck coefficients and ``col`` (6) with the coefficients of theta'' in
    the deck rows of :func:`abb_ros.model.dynamics.kernels.eom.assemble` (the terms it moves to the
    right when theta'' is known); returns J_z + I_r, the coefficient of theta'' (the balls'
    column is m R^2).
    """
    R, M, m, J_z, eps = P[P_R], P[P_M], P[P_m], P[P_J_z], P[P_EPS]
    al, be, ga = y[DECK + 3], y[DECK + 4], y[DECK + 5]
    S1 = 0.0
    C1 = 0.0
    for j in range(n + 1):
        if j == 0:
            mr = M * eps
            psi = y[THETA]
        else:
            mr = m * R
            psi = y[THETA] + y[PHI - 1 + j]
        S1 += mr * math.sin(psi)
        C1 += mr * math.cos(psi)
    I_th = J_z + M * eps * eps + n * m * R * R
    a[0] = -S1
    a[1] = C1
    a[2] = 0.0
    a[3] = 0.0
    a[4] = 0.0
    a[5] = I_th
    col[0] = -S1 - ga * C1
    col[1] = C1 - ga * S1
    col[2] = al * C1 + be * S1
    col[3] = be * I_th
    col[4] = 0.0
    col[5] = I_th
    return I_th


@kernel
def accel_free_theta(t, y, n, P, S, qdd, solver):  # noqa: ARG001 (every q'' kernel's signature)
    """Fill qdd with q'' for theta a degree of freedom driven by Q_theta.

    Q_theta = :func:`abb_ros.model.dynamics.kernels.spindle.spindle_torque`.

    The deck and ball rows of :func:`abb_ros.model.dynamics.kernels.eom.assemble` (assembled with
    theta'' = 0, the column of theta'' from :func:`theta_row`) and the theta row: the balls are
    eliminated from both (block m R^2 I), the deck solved for the right-hand side and for
    theta'''s column (:func:`abb_ros.model.dynamics.kernels.eom.solve_deck`), theta'' from the
    theta row (a scalar Schur complement, the rotor inertia the motor sees), then
    back-substitution.
    """
    A, W, f, B, fb, u = solver.A, solver.W, solver.f, solver.B, solver.fb, solver.u
    N = PHI + n
    assemble(y, n, P, 0.0, A, W, f, B, fb)
    a = np.empty(6)
    col = np.empty(6)
    uc = np.empty(6)
    I_th = theta_row(y, n, P, a, col)
    Q = spindle_torque(y[N + THETA], S)
    mR2 = P[P_m] * P[P_R] * P[P_R]
    inv = 1.0 / mR2
    eliminate_balls(n, n, inv, inv, A, W, f, B, fb)
    for i in range(6):
        for b in range(n):
            w = W[i, b] * inv
            if w != 0.0:
                col[i] -= w * mR2
    for b in range(n):
        # in the theta row, m R^2 phi_b'' = fb_b - B_b u - m R^2 theta''
        a[0] -= B[b, 0]
        a[1] -= B[b, 1]
        a[5] -= B[b, 5]
        Q -= fb[b]
        I_th -= mR2
    solve_deck(A, f, u)
    solve_deck(A, col, uc)
    num = Q
    den = I_th
    for i in range(6):
        num -= a[i] * u[i]
        den -= a[i] * uc[i]
    thdd = num / den
    qdd[THETA] = thdd
    for i in range(6):
        u[i] -= uc[i] * thdd
        qdd[DECK + i] = u[i]
    for b in range(n):
        acc = fb[b] - mR2 * thdd
        for j in range(6):
            acc -= B[b, j] * u[j]
        qdd[PHI + b] = acc * inv

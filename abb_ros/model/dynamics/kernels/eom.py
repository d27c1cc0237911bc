"""The equations of motion: the rows of Eqs. (18)-(24) and their solution for q''.

:func:`assemble` builds the deck rows (X, Y, Z, alpha, beta, gamma; Eqs. 18-23) A u + W phi''
= f and the ball rows (Eq. 24) B u + m R^2 phi'' = fb for a known theta''; the solvers
eliminate the balls (:func:`eliminate_balls`) and solve the deck (:func:`solve_deck`, block
triangular to the paper's order: two 3 x 3 solves, :func:`solve3`).
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics.kernels.ball_size import add_ball_rotation
from abb_ros.model.dynamics.kernels.contact import contact_forces
from abb_ros.model.dynamics.kernels.layout import (
    P_A,
    P_B,
    P_BALL_ROTATION,
    P_C,
    P_CONTACT_E,
    P_D,
    P_DRAG,
    P_EPS,
    P_K,
    P_M,
    P_M_P,
    P_R,
    P_J_Px,
    P_J_Py,
    P_J_Pz,
    P_J_x,
    P_J_y,
    P_J_z,
    P_m,
    kernel,
)
from abb_ros.model.dynamics.state import DECK, PHI, THETA


@kernel
def assemble(y, n, P, thdd, A, W, f, B, fb):
    """Fill the rows of Eqs. (18)-(24), generalised to theta(t), into A, W, f, B, fb.

    :func:`assemble_rows`, with the balls' contact forces
    (:func:`abb_ros.model.dynamics.kernels.contact.contact_forces`) in the ball rows and, for
    rolling balls, their spin (:func:`abb_ros.model.dynamics.kernels.ball_size.add_ball_rotation`).
    """
    assemble_rows(y, n, P, thdd, A, W, f, B, fb)
    if P[P_CONTACT_E] > 0.0 and n > 1:
        Qc = np.empty(n)
        contact_forces(y, n, P, Qc)
        for i in range(n):
            fb[i] += Qc[i]
    if P[P_BALL_ROTATION] != 0.0:
        add_ball_rotation(y, n, P, thdd, A, W, f, B, fb)


@kernel(inline=True)
def assemble_rows(y, n, P, thdd, A, W, f, B, fb):
    """Fill the rows of Eqs. (18)-(24) of point-mass balls with no contact into A, W, f, B, fb.

    Deck rows (X, Y, Z, alpha, beta, gamma): A @ u + W @ phi'' = f, with u the deck
    accelerations; ball rows: B @ u + m R^2 phi'' = fb. The rotor's mass centre G is
    treated like a ball of mass M at radius eps and angle theta whose angle has a known
    second derivative theta''; every phi_i'' of the paper is the ball's acceleration
    relative to the rotor, and the inertial angle psi_i = phi_i + theta has psi_i'' =
    phi_i'' + theta''. Compiled in place (into :func:`assemble` and
    :func:`~abb_ros.model.dynamics.kernels.rhs.paper_deriv`).
    """
    a, b, d, R = P[P_A], P[P_B], P[P_D], P[P_R]
    M_P, M, m = P[P_M_P], P[P_M], P[P_m]
    J_Px, J_Py, J_Pz = P[P_J_Px], P[P_J_Py], P[P_J_Pz]
    J_x, J_y, J_z = P[P_J_x], P[P_J_y], P[P_J_z]
    k, c, D, eps = P[P_K], P[P_C], P[P_DRAG], P[P_EPS]
    N = PHI + n
    X, Y, Z, al, be, ga = (y[DECK], y[DECK + 1], y[DECK + 2], y[DECK + 3], y[DECK + 4],
                           y[DECK + 5])
    om = y[N + THETA]
    Xd, Yd, Zd, ald, bed, gad = (y[N + DECK], y[N + DECK + 1], y[N + DECK + 2],
                                 y[N + DECK + 3], y[N + DECK + 4], y[N + DECK + 5])
    Mt = M + M_P + n * m

    # Sums over the rotating point masses j = G (M, eps, theta) and balls (m, R, phi_i + theta),
    # with the known part psi'' = theta'' of their angular accelerations.
    S1 = 0.0   # sum mu r sin(psi)
    C1 = 0.0   # sum mu r cos(psi)
    Sss = 0.0  # sum mu r^2 sin^2
    Scc = 0.0  # sum mu r^2 cos^2
    Ssc = 0.0  # sum mu r^2 sin cos
    Wsc = 0.0  # sum mu r^2 psi' sin cos
    Wss = 0.0  # sum mu r^2 psi' sin^2
    Wcc = 0.0  # sum mu r^2 psi' cos^2
    FX = 0.0   # known inertial terms moved to the right of the X, Y, Z rows
    FY = 0.0
    FZ = 0.0
    for j in range(n + 1):
        if j == 0:
            mu = M
            r = eps
            psi = y[THETA]
            psid = om
        else:
            mu = m
            r = R
            psi = y[THETA] + y[PHI - 1 + j]
            psid = om + y[N + PHI - 1 + j]
        s = math.sin(psi)
        co = math.cos(psi)
        mr = mu * r
        mr2 = mr * r
        S1 += mr * s
        C1 += mr * co
        Sss += mr2 * s * s
        Scc += mr2 * co * co
        Ssc += mr2 * s * co
        Wsc += mr2 * psid * s * co
        Wss += mr2 * psid * s * s
        Wcc += mr2 * psid * co * co
        # Eq. (18): -mu r {[g'' + psi'' - psi'^2 g] sin + [g psi'' + psi'(2 g' + psi')] cos}
        tX = (thdd - psid * psid * ga) * s + (ga * thdd + psid * (2.0 * gad + psid)) * co
        # Eq. (19): +mu r {[g'' + psi'' - psi'^2 g] cos - [g psi'' + psi'(2 g' + psi')] sin}
        tY = (thdd - psid * psid * ga) * co - (ga * thdd + psid * (2.0 * gad + psid)) * s
        # Eq. (20): +mu r {[-b'' + a psi'' + 2 psi' a' + psi'^2 b] cos
        #                  + [a'' + b psi'' + 2 psi' b' - psi'^2 a] sin}
        tZ = ((al * thdd + 2.0 * psid * ald + psid * psid * be) * co
              + (be * thdd + 2.0 * psid * bed - psid * psid * al) * s)
        FX += mr * tX
        FY -= mr * tY
        FZ -= mr * tZ
        if j > 0:
            # ball i = j - 1: its accelerations' coefficients in the deck rows, and Eq. (24)
            i = j - 1
            W[0, i] = -mr * (s + ga * co)
            W[1, i] = mr * (co - ga * s)
            W[2, i] = mr * (al * co + be * s)
            W[3, i] = mr2 * be
            W[4, i] = 0.0
            W[5, i] = mr2
            B[i, 0] = -mr * s
            B[i, 1] = mr * co
            B[i, 2] = 0.0
            B[i, 3] = 0.0
            B[i, 4] = 0.0
            B[i, 5] = mr2
            fb[i] = -D * y[N + PHI + i] - mr2 * thdd
    Ir = M * eps * eps + n * m * R * R
    kb = b * b + 4.0 * d * d
    kab = a * a + b * b + 4.0 * d * d

    for i in range(6):
        for j in range(6):
            A[i, j] = 0.0
    # Eq. (18), X
    A[0, 0] = Mt
    A[0, 5] = M_P * d - S1
    f[0] = -4.0 * c * Xd - 4.0 * k * X - 4.0 * d * c * gad - 4.0 * d * k * ga + FX
    # Eq. (19), Y
    A[1, 1] = Mt
    A[1, 5] = C1
    f[1] = -4.0 * c * Yd - 4.0 * k * Y + FY
    # Eq. (20), Z
    A[2, 2] = Mt
    A[2, 3] = -M_P * d + S1
    A[2, 4] = -C1
    f[2] = -4.0 * c * Zd - 4.0 * k * Z + 4.0 * d * c * ald + 4.0 * d * k * al + FZ
    # Eq. (21), alpha
    A[3, 3] = J_x + J_Px + M_P * d * d + Sss
    A[3, 4] = -Ssc
    A[3, 2] = -M_P * d + S1
    f[3] = (-(kb * c + 2.0 * Wsc) * ald - kb * k * al - (J_z * om + 2.0 * Wss) * bed
            + 4.0 * d * c * Zd + 4.0 * d * k * Z - be * (Ir + J_z) * thdd)
    # Eq. (22), beta
    A[4, 4] = J_y + J_Py + Scc
    A[4, 3] = -Ssc
    A[4, 2] = -C1
    f[4] = -(a * a * c - 2.0 * Wsc) * bed - a * a * k * be + (J_z * om + 2.0 * Wcc) * ald
    # Eq. (23), gamma
    A[5, 5] = J_z + J_Pz + M_P * d * d + Ir
    A[5, 0] = M_P * d - S1
    A[5, 1] = C1
    f[5] = (-kab * (c * gad + k * ga) - 4.0 * d * c * Xd - 4.0 * d * k * X
            - (Ir + J_z) * thdd)


@kernel
def solve3(A, f, i0, i1, i2, u):
    """Solve rows and columns (i0, i1, i2) of A u = f for u[i0], u[i1], u[i2].

    Gaussian elimination with partial pivoting on the 3 x 3 block (A and f are not
    modified).
    """
    a00, a01, a02 = A[i0, i0], A[i0, i1], A[i0, i2]
    a10, a11, a12 = A[i1, i0], A[i1, i1], A[i1, i2]
    a20, a21, a22 = A[i2, i0], A[i2, i1], A[i2, i2]
    b0, b1, b2 = f[i0], f[i1], f[i2]
    # pivot column 0
    if abs(a10) > abs(a00) and abs(a10) >= abs(a20):
        a00, a01, a02, b0, a10, a11, a12, b1 = a10, a11, a12, b1, a00, a01, a02, b0
    elif abs(a20) > abs(a00):
        a00, a01, a02, b0, a20, a21, a22, b2 = a20, a21, a22, b2, a00, a01, a02, b0
    l1 = a10 / a00
    l2 = a20 / a00
    a11 -= l1 * a01
    a12 -= l1 * a02
    b1 -= l1 * b0
    a21 -= l2 * a01
    a22 -= l2 * a02
    b2 -= l2 * b0
    # pivot column 1
    if abs(a21) > abs(a11):
        a11, a12, b1, a21, a22, b2 = a21, a22, b2, a11, a12, b1
    l2 = a21 / a11
    a22 -= l2 * a12
    b2 -= l2 * b1
    x2 = b2 / a22
    x1 = (b1 - a12 * x2) / a11
    x0 = (b0 - a01 * x1 - a02 * x2) / a00
    u[i0] = x0
    u[i1] = x1
    u[i2] = x2


@kernel
def solve_deck(A, f, u):
    """Solve A u = f for the deck accelerations u.

    To the paper's order the in-plane rows (X, Y,
    gamma: Eqs. 18, 19, 23 with the balls eliminated) hold no out-of-plane acceleration,
    so the system is block triangular: a 3 x 3 in-plane solve, then a 3 x 3 out-of-plane
    solve (Z, alpha, beta) with the in-plane accelerations moved to the right.
    """
    solve3(A, f, 0, 1, 5, u)
    for r in range(2, 5):
        f[r] -= A[r, 0] * u[0] + A[r, 1] * u[1] + A[r, 5] * u[5]
    solve3(A, f, 2, 3, 4, u)


@kernel
def eliminate_balls(n, inv, A, W, f, B, fb):
    """Eliminate the ball rows from the deck rows (Schur complement), in place.

    The balls' block is m R^2 I, ``inv`` its inverse: A -= W B / m R^2, f -= W fb / m R^2.
    """
    for i in range(6):
        for b in range(n):
            w = W[i, b] * inv
            if w != 0.0:
                # Eq. (24) involves X'', Y'' and gamma'' only (B[:, 2:5] = 0)
                A[i, 0] -= w * B[b, 0]
                A[i, 1] -= w * B[b, 1]
                A[i, 5] -= w * B[b, 5]
                f[i] -= w * fb[b]

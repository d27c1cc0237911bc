"""The equations of motion: the rows of Eqs. (18)-(24) and their solution for q''.

:func:`assemble` builds the deck rows (X, Y, Z, alpha, beta, gamma; Eqs. 18-23) A u + W phi''
= f and the ball rows (Eq. 24) B u + m R^2 phi'' = fb for a known theta''; the solvers
eliminate the balls (:func:`eliminate_balls`) and solve the deck (:func:`solve_deck`, block
triangular to the paper's order: two 3 x 3 solves, :func:`solve3`; one coupled 6 x 6 solve,
:func:`solve6`, where mass centres off the washers' plane or a leaning rotor axis couple the
groups, docs/equations.md F4, F6).
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
    P_PSI_TAU,
    P_R,
    P_TAU,
    P_Z_B,
    P_Z_G,
    P_Z_P,
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
    add_offsets(y, n, P, thdd, A, W, f, B)
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


@kernel(inline=True)
def add_offsets(y, n, P, thdd, A, W, f, B):
    """Add the heights' and the leaning axis' terms where they are set (none: the paper's rows).

    :func:`add_heights`, :func:`add_leaning_axis`.
    """
    if P[P_Z_P] != 0.0 or P[P_Z_G] != 0.0 or P[P_Z_B] != 0.0:
        add_heights(y, n, P, thdd, A, W, f, B)
    if P[P_TAU] != 0.0:
        add_leaning_axis(y, n, P, thdd, A, f)


@kernel
def add_heights(y, n, P, thdd, A, W, f, B):
    """Add the terms of mass centres off the washers' plane to the rows (docs/equations.md, F4).

    P at height z_P, G at z_G and the balls at z_B above the plane of the washer attachment
    points (which holds C): Lagrange's equations of the energies of Eqs. (11), (13), (16) with
    these heights, to first order in the deck coordinates, less those of the paper's plane
    (test/model/dynamics/test_heights_vs_lagrange.py derives both). Each point mass
    couples tilt and translation (the X, Y rows gain beta'', alpha''), and a ball's row gains
    alpha'' and beta'', so the deck's rows no longer split in-plane and out-of-plane.
    """
    N = PHI + n
    al, be, gad = y[DECK + 3], y[DECK + 4], y[N + DECK + 5]
    om = y[N + THETA]
    # P at (0, -d, z_P): sin = -1, cos = 0, fixed in the deck
    add_point_at_height(P[P_M_P], P[P_D], P[P_Z_P], -1.0, 0.0, 0.0, (al, be, gad), A, f)
    # G at (eps cos theta, eps sin theta, z_G): its angle's acceleration theta'' is known
    mh = P[P_M] * P[P_Z_G]
    r = P[P_EPS]
    s = math.sin(y[THETA])
    c = math.cos(y[THETA])
    add_point_at_height(P[P_M], r, P[P_Z_G], s, c, om, (al, be, gad), A, f)
    f[3] += mh * r * c * thdd
    f[4] += mh * r * s * thdd
    f[5] -= mh * r * (be * c - al * s) * thdd
    # ball i at (R cos psi_i, R sin psi_i, z_B), psi_i = theta + phi_i
    mh = P[P_m] * P[P_Z_B]
    r = P[P_R]
    for i in range(n):
        psi = y[THETA] + y[PHI + i]
        s = math.sin(psi)
        c = math.cos(psi)
        add_point_at_height(P[P_m], r, P[P_Z_B], s, c, om + y[N + PHI + i], (al, be, gad), A, f)
        # psi_i'' = phi_i'' + theta'': the ball's column, and the known theta'' to the right
        W[3, i] -= mh * r * c
        W[4, i] -= mh * r * s
        W[5, i] += mh * r * (be * c - al * s)
        f[3] += mh * r * c * thdd
        f[4] += mh * r * s * thdd
        f[5] -= mh * r * (be * c - al * s) * thdd
        B[i, 3] -= mh * r * c
        B[i, 4] -= mh * r * s


@kernel
def add_leaning_axis(y, n, P, thdd, A, f):
    """Add the terms of the rotor's leaning principal axis (couple imbalance; equations.md F6).

    The axis leans by tau toward the rotor-fixed direction psi_tau from G: J_G = J_x I +
    (J_z - J_x) n n^T with n = (sin tau cos phi, sin tau sin phi, cos tau), phi = theta +
    psi_tau (exact in tau, J_x = J_y). Lagrange's equations of the added energy
    1/2 (J_z - J_x) [(n . w)^2 - w_z^2], w the rotor's angular velocity, to first order in the
    deck coordinates (sympy, test/lagrange_sympy.py): k = (J_z - J_x) sin tau cos tau is the
    couple (the rotating moment k omega^2), q = (J_z - J_x) sin^2 tau lowers the spin inertia.
    """
    N = PHI + n
    al, be = y[DECK + 3], y[DECK + 4]
    ald, bed, gad = y[N + DECK + 3], y[N + DECK + 4], y[N + DECK + 5]
    w = y[N + THETA]
    dJ = P[P_J_z] - P[P_J_x]
    st, ct = math.sin(P[P_TAU]), math.cos(P[P_TAU])
    k, q = dJ * st * ct, dJ * st * st
    phi = y[THETA] + P[P_PSI_TAU]
    s, c = math.sin(phi), math.cos(phi)
    A[3, 3] += q * c * c
    A[3, 4] += q * s * c
    A[3, 5] += k * c
    f[3] -= (k * (thdd * c - w * w * s) - q * thdd * be - 2.0 * q * w * (s * s * bed + s * c * ald)
             - 2.0 * k * w * s * gad)
    A[4, 3] += q * s * c
    A[4, 4] += q * s * s
    A[4, 5] += k * s
    f[4] -= (k * (w * w * c + thdd * s) + 2.0 * q * w * (c * c * ald + s * c * bed)
             + 2.0 * k * w * c * gad)
    A[5, 3] += k * c
    A[5, 4] += k * s
    A[5, 5] -= q
    f[5] -= -q * thdd + k * (al * (w * w * c + thdd * s) + be * (w * w * s - thdd * c))


@kernel(inline=True)
def add_point_at_height(mu, r, h, s, c, w, tilt, A, f):
    """Add one point mass mu at (r cos psi, r sin psi, h) in the deck's axes: terms of h only.

    ``s, c`` = sin, cos psi, ``w`` = psi', ``tilt`` = (alpha, beta, gamma'); the terms in
    psi'' are the caller's (its column, or known). First order in the deck coordinates, as
    :func:`add_heights`.
    """
    al, be, gad = tilt
    mh = mu * h
    A[0, 4] += mh
    A[1, 3] -= mh
    A[3, 1] -= mh
    A[3, 3] += mh * h
    A[3, 5] -= mh * r * c
    A[4, 0] += mh
    A[4, 4] += mh * h
    A[4, 5] -= mh * r * s
    A[5, 3] -= mh * r * c
    A[5, 4] -= mh * r * s
    f[3] -= mh * r * s * w * (2.0 * gad + w)
    f[4] += mh * r * c * w * (2.0 * gad + w)
    f[5] += mh * r * w * w * (al * c + be * s)


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
    solve (Z, alpha, beta) with the in-plane accelerations moved to the right. Heights off
    the plane (F4) put tilt accelerations in the in-plane rows: then one 6 x 6 solve.
    """
    for r in (0, 1, 5):
        if A[r, 2] != 0.0 or A[r, 3] != 0.0 or A[r, 4] != 0.0:
            solve6(A, f, u)          # mass centres off the plane couple the two groups
            return
    solve3(A, f, 0, 1, 5, u)
    for r in range(2, 5):
        f[r] -= A[r, 0] * u[0] + A[r, 1] * u[1] + A[r, 5] * u[5]
    solve3(A, f, 2, 3, 4, u)


@kernel
def solve6(A, f, u):
    """Solve the whole 6 x 6 system A u = f (partial pivoting; A and f are not modified)."""
    T = np.empty((6, 7))
    for i in range(6):
        for j in range(6):
            T[i, j] = A[i, j]
        T[i, 6] = f[i]
    for col in range(6):
        pivot_row(T, col)
        for r in range(col + 1, 6):
            lr = T[r, col] / T[col, col]
            for j in range(col, 7):
                T[r, j] -= lr * T[col, j]
    for i in range(5, -1, -1):
        acc = T[i, 6]
        for j in range(i + 1, 6):
            acc -= T[i, j] * u[j]
        u[i] = acc / T[i, i]


@kernel(inline=True)
def pivot_row(T, col):
    """Swap into row ``col`` of T the row at or below it with the largest entry in ``col``."""
    piv = col
    for r in range(col + 1, 6):
        if abs(T[r, col]) > abs(T[piv, col]):
            piv = r
    if piv != col:
        for j in range(col, 7):
            T[col, j], T[piv, j] = T[piv, j], T[col, j]


@kernel
def eliminate_balls(n, inv, A, W, f, B, fb):
    """Eliminate the ball rows from the deck rows (Schur complement), in place.

    The balls' block is m R^2 I, ``inv`` its inverse: A -= W B / m R^2, f -= W fb / m R^2.
    """
    for i in range(6):
        for b in range(n):
            w = W[i, b] * inv
            if w != 0.0:
                # in the plane, Eq. (24) involves X'', Y'', gamma'' only (B[:, 2:5] = 0)
                A[i, 0] -= w * B[b, 0]
                A[i, 1] -= w * B[b, 1]
                A[i, 5] -= w * B[b, 5]
                f[i] -= w * fb[b]
                if B[b, 3] != 0.0 or B[b, 4] != 0.0:    # a race off the plane (F4)
                    A[i, 3] -= w * B[b, 3]
                    A[i, 4] -= w * B[b, 4]

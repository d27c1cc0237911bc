"""The multirate contact step (MIS): contact forces sub-stepped, the rest per stage.

While balls touch, their contact forces (:mod:`abb_ros.model.dynamics.kernels.contact`) are far
faster than the rest of the drive (Eqs. 18-24). :func:`mis_contact_step` is a multirate
infinitesimal step (Wensch, Knoth, Galant 2009) on Knoth & Wolke's three-stage RK (:data:`MIS_A`,
:data:`MIS_C`): the slow part (the accelerations without contact) at its three stages, the
fast part (:mod:`abb_ros.model.dynamics.kernels.multirate_fast`) by RK4 sub-steps in between.
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics.kernels.ball_size import ball_inertia, spin_coupling
from abb_ros.model.dynamics.kernels.contact_steps import MIS_IMPACT_REFINE, retake_substeps
from abb_ros.model.dynamics.kernels.eom import solve_deck
from abb_ros.model.dynamics.kernels.layout import P_CONTACT_E, P_DRAG, P_R, P_R_BALL, P_m, kernel
from abb_ros.model.dynamics.kernels.multirate_fast import (
    FastPart,
    mis_fast_solve,
    neighbour_pairs,
    neighbour_reference,
)
from abb_ros.model.dynamics.kernels.rhs import accel
from abb_ros.model.dynamics.state import DECK, PHI, THETA

MIS_A = np.array([[0.0, 0.0, 0.0], [1.0 / 3.0, 0.0, 0.0], [-3.0 / 16.0, 15.0 / 16.0, 0.0],
                  [1.0 / 6.0, 3.0 / 10.0, 8.0 / 15.0]])
"""Knoth & Wolke's third-order three-stage RK (rows 0-2: a_ij, row 3: b_j), the slow method of
the multirate contact step (:func:`mis_contact_step`; MIS: Wensch, Knoth, Galant 2009)."""
MIS_C = np.array([0.0, 1.0 / 3.0, 3.0 / 4.0, 1.0])
"""Its stage times c_i, and 1."""


@kernel
def velocity_coupling(y, n, P, inv, Ainv, W, B, Jv):
    """Fill Jv (N x n) with d q'' / d phi_b' at y, the balls' rate coupling.

    Jv[:, b] = d q'' / d phi_b' at y (N x n), of the terms of
    :func:`abb_ros.model.dynamics.kernels.eom.assemble` and
    :func:`abb_ros.model.dynamics.kernels.ball_size.add_ball_rotation` in the balls' rates psi_b' =
    theta' + phi_b' (Eqs. 18-22: Coriolis and centrifugal; the ball's drag D), through the
    coupled system: Ainv the inverse of the eliminated deck rows, W and B as
    :func:`abb_ros.model.dynamics.kernels.rhs.accel` leaves them, inv = 1 / m R^2.
    """
    N = PHI + n
    R, m, D = P[P_R], P[P_m], P[P_DRAG]
    mr = m * R
    mr2 = mr * R
    JbRr = spin_coupling(P)
    al, be, ga = y[DECK + 3], y[DECK + 4], y[DECK + 5]
    ald, bed, gad = y[N + DECK + 3], y[N + DECK + 4], y[N + DECK + 5]
    df = np.empty(6)
    du = np.empty(6)
    for b in range(n):
        psi = y[THETA] + y[PHI + b]
        psid = y[N + THETA] + y[N + PHI + b]
        s = math.sin(psi)
        co = math.cos(psi)
        df[0] = mr * (-2.0 * psid * ga * s + 2.0 * (gad + psid) * co)
        df[1] = mr * (2.0 * psid * ga * co + 2.0 * (gad + psid) * s)
        df[2] = -2.0 * mr * ((ald + psid * be) * co + (bed - psid * al) * s)
        df[3] = -2.0 * mr2 * s * (co * ald + s * bed) + JbRr * bed
        df[4] = 2.0 * mr2 * co * (s * bed + co * ald) - JbRr * ald
        df[5] = 0.0
        for row in range(6):
            df[row] += W[row, b] * D * inv        # the ball row's -D, eliminated
        for row in range(6):
            du[row] = 0.0
            for col in range(6):
                du[row] += Ainv[row, col] * df[col]
        Jv[THETA, b] = 0.0
        for row in range(6):
            Jv[DECK + row, b] = du[row]
        for c in range(n):
            Jv[PHI + c, b] = -inv * (B[c, 0] * du[0] + B[c, 1] * du[1] + B[c, 5] * du[5])
        Jv[PHI + b, b] -= inv * D


@kernel
def deck_inverse(A, f, u, Ainv):
    """Fill Ainv with the inverse of the eliminated deck matrix A, column by column.

    ``f`` and ``u`` (6) are scratch for :func:`solve_deck`.
    """
    for col in range(6):
        for row in range(6):
            f[row] = 1.0 if row == col else 0.0
        solve_deck(A, f, u)
        for row in range(6):
            Ainv[row, col] = u[row]


@kernel
def stage_forcing(i, y, n, qdd, Jv, v0, F, g):
    """Store the slow part of MIS stage ``i`` in F[i]; put the next fast stretch's forcing in g.

    The slow part is the accelerations without contact ``qdd`` minus Jv (phi' - v0); the
    forcing is the stages' combination (:data:`MIS_A`) over the stretch to stage i + 1, of
    length ``span`` = MIS_C[i + 1] - MIS_C[i] (in steps), which is returned.
    """
    N = PHI + n
    for c in range(N):
        F[i, c] = qdd[c]
    for b in range(n):
        dv = y[N + PHI + b] - v0[b]
        for c in range(N):
            F[i, c] -= Jv[c, b] * dv
    span = MIS_C[i + 1] - MIS_C[i]
    for c in range(N):
        s = 0.0
        for j in range(i + 1):
            s += (MIS_A[i + 1, j] - MIS_A[i, j]) * F[j, c]
        g[c] = s / span
    return span


@kernel
def mis_contact_step(t, dt, y, n, P, S, sub, trace, solver):
    """Take one step of dt from (t, y) while balls touch, y in place; return its sub-steps.

    A multirate infinitesimal step (MIS: Wensch, Knoth, Galant 2009) on Knoth & Wolke's
    three-stage RK (third order, :data:`MIS_A`, :data:`MIS_C`).

    The right-hand side is split into a fast part, the positions' rates, the accelerations C0
    Qc that the contact forces of the neighbour pairs cause through the coupled system and the
    linear change of the rate-dependent terms with the balls' rates since the step's start (an
    impact changes them within a step; :func:`mis_fast_solve`), and a slow part, the
    accelerations without contact (:func:`abb_ros.model.dynamics.kernels.rhs.accel`) minus that
    linear change (so that no contact spike is sampled at a stage). The slow part is evaluated at
    the three stages only; from stage to stage the fast part is integrated by RK4 sub-steps of at
    most dt / sub with the slow part's stage combination as a constant forcing: a sub-step
    costs O(n), not a coupled solve. Row r of ``trace`` (when it has rows) receives sub-step r:
    [its start time, its length, the state after it]; ``solver``: the scratch of
    :func:`abb_ros.model.dynamics.kernels.rhs.accel`. Returns the number of sub-steps. Speed-driven
    spindle, no rolling resistance (:func:`abb_ros.model.dynamics.kernels.stepper.step`).
    """
    A, W, f, B, u, qdd = solver.A, solver.W, solver.f, solver.B, solver.u, solver.qdd
    N = PHI + n
    inv = 1.0 / ball_inertia(P)
    reach = math.asin(P[P_R_BALL] / P[P_R])
    pairs = neighbour_pairs(y, n)
    ref = np.empty((pairs.shape[0], 4))
    neighbour_reference(y, pairs, ref)
    Ainv = np.empty((6, 6))
    psi = np.empty((n + 1, 3))
    for b in range(n):
        psi[b, 0] = y[PHI + b]
        psi[b, 1] = math.sin(y[THETA] + y[PHI + b])
        psi[b, 2] = math.cos(y[THETA] + y[PHI + b])
    psi[n, 0] = y[THETA]
    Jv = np.empty((N, n))
    Bs = np.empty((n, 3))
    v0 = y[N + PHI:].copy()
    k = np.empty((4, 2 * N))
    yt = np.empty(2 * N)
    F = np.empty((3, N))
    g = np.zeros(N)
    Qc = np.empty(n)
    sc = np.empty((2, n))
    fast = FastPart(reach, inv, pairs, ref, Ainv, psi, Jv, Bs, v0, g, Qc, sc, k, yt)
    rows = 0
    P_slow = P.copy()
    P_slow[P_CONTACT_E] = 0.0
    for i in range(3):
        t_i = t + MIS_C[i] * dt
        accel(t_i, y, n, P_slow, S, qdd, solver)
        if i == 0:
            deck_inverse(A, f, u, Ainv)   # A is now the eliminated deck matrix
            velocity_coupling(y, n, P, inv, Ainv, W, B, Jv)
            for b in range(n):      # B's columns of Jv's ball rows, at the step's start
                Bs[b, 0] = B[b, 0]
                Bs[b, 1] = B[b, 1]
                Bs[b, 2] = B[b, 5]
        span = stage_forcing(i, y, n, qdd, Jv, v0, F, g)
        m = max(1, int(math.ceil(sub * span - 1e-9)))
        rows = mis_fast_solve(t_i, m, span * dt / m, y, n, P, fast, trace, rows)
    return rows


@kernel
def contact_step(t, dt, y, start, n, P, S, regime, trace, solver):
    """Take the multirate step of dt from (t, y), y in place; return its fast sub-steps.

    ``start``: a copy of y, kept. The fast sub-steps follow the contact regime ``regime`` =
    (sub-steps, impact) of :func:`abb_ros.model.dynamics.kernels.contact_steps.contact_regime`
    (:func:`abb_ros.model.dynamics.kernels.contact_steps.mis_substeps`); the step is taken again
    from ``start`` when :func:`abb_ros.model.dynamics.kernels.contact_steps.retake_substeps` says
    so. Returns the fast sub-steps (``trace``'s rows, of the step kept), as
    :func:`mis_contact_step`.
    """
    sub, impact = regime
    fast = int(math.ceil(sub * MIS_IMPACT_REFINE)) if impact else sub
    rows = mis_contact_step(t, dt, y, n, P, S, fast, trace, solver)
    forced = retake_substeps(start, y, n, P, dt, impact, fast, MIS_IMPACT_REFINE)
    if forced > 0:
        y[:] = start
        rows = mis_contact_step(t, dt, y, n, P, S, forced, trace, solver)
    return rows

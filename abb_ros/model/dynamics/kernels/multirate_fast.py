"""The fast part of the multirate contact step: the contact forces between neighbours.

Within a step of :func:`abb_ros.model.dynamics.kernels.multirate.mis_contact_step` the contact
forces (:mod:`abb_ros.model.dynamics.kernels.contact`) of the neighbour pairs (only balls next to
each other on the race can touch) are integrated by RK4 sub-steps with a constant forcing for the
rest (:func:`mis_fast_solve`); while no pair touches or can touch soon, several sub-steps are taken
as one (:func:`apart_substeps`).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from abb_ros.model.dynamics.kernels.ball_size import spin_coupling
from abb_ros.model.dynamics.kernels.contact import contact_stiffness, hertz_force
from abb_ros.model.dynamics.kernels.layout import (
    P_CONTACT_DAMPING,
    P_DRAG,
    P_R,
    P_R_BALL,
    P_m,
    kernel,
)
from abb_ros.model.dynamics.kernels.rk4 import rk4_combine, rk4_stage_point
from abb_ros.model.dynamics.state import DECK, PHI, THETA

MIS_APART_MARGIN = 2.0
"""The multirate step's fast sub-steps are merged into one only while every pair of balls
stays apart for this many times their length at its present closing rate
(:func:`apart_substeps`)."""

FastPart = namedtuple('FastPart', ['reach', 'inv', 'pairs', 'ref', 'Ainv', 'psi', 'Jv', 'Bs',
                                   'v0', 'g', 'Qc', 'sc', 'k', 'yt'])
"""What the fast part of a multirate step holds fixed over the step and its scratch
(:func:`mis_fast_solve`, :func:`abb_ros.model.dynamics.kernels.multirate.mis_contact_step`)."""


@kernel
def neighbour_pairs(y, n):
    """Return the pairs of balls next to each other on the race, (n, 2).

    The pairs of balls next to each other on the race, (n, 2) (one pair for n = 2): the balls
    sorted by angle, each with the next (cyclically). Balls in contact cannot pass each other,
    so only these pairs can touch within a step.
    """
    angle = np.empty(n)
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        a = y[PHI + i] - 2.0 * math.pi * math.floor(y[PHI + i] / (2.0 * math.pi))
        k = i
        while k > 0 and angle[k - 1] > a:       # insertion sort
            angle[k] = angle[k - 1]
            order[k] = order[k - 1]
            k -= 1
        angle[k] = a
        order[k] = i
    npairs = 1 if n == 2 else n
    pairs = np.empty((npairs, 2), dtype=np.int64)
    for k in range(npairs):
        pairs[k, 0] = order[k]
        pairs[k, 1] = order[(k + 1) % n]
    return pairs


@kernel
def neighbour_reference(y, n, pairs, ref):
    """Fill ref with the reference angles of the neighbour pairs at y.

    ref[k] = [its wrap 2 pi w, half-angle h0, sin h0, cos h0] of neighbour pair k at y (half =
    (phi_j - phi_i - 2 pi w) / 2 as in :func:`pair_state`), the reference of
    :func:`mis_fast_solve` within the step.
    """
    for k in range(pairs.shape[0]):
        d = y[PHI + pairs[k, 1]] - y[PHI + pairs[k, 0]]
        w = 2.0 * math.pi * math.floor(d / (2.0 * math.pi) + 0.5)
        half = 0.5 * (d - w)
        ref[k, 0] = w
        ref[k, 1] = half
        ref[k, 2] = math.sin(half)
        ref[k, 3] = math.cos(half)


@kernel
def sincos_near(h0, s0, c0, e):
    """Return (sin, cos) of h0 + e from s0 = sin h0 and c0 = cos h0.

    (sin, cos) of h0 + e from s0 = sin h0 and c0 = cos h0: the addition theorem with the Taylor
    series of sin e and cos e (round-off for |e| < 0.1), else math.sin, cos.
    """
    if abs(e) >= 0.1:
        return math.sin(h0 + e), math.cos(h0 + e)
    e2 = e * e
    sin_e = e * (1.0 - e2 * (1.0 / 6.0) * (1.0 - e2 * (1.0 / 20.0) * (
        1.0 - e2 * (1.0 / 42.0) * (1.0 - e2 * (1.0 / 72.0)))))
    cos_e = 1.0 - e2 * 0.5 * (1.0 - e2 * (1.0 / 12.0) * (1.0 - e2 * (1.0 / 30.0) * (
        1.0 - e2 * (1.0 / 56.0) * (1.0 - e2 * (1.0 / 90.0)))))
    return s0 * cos_e + c0 * sin_e, c0 * cos_e - s0 * sin_e


@kernel
def ball_sincos(psi, st, ct, b, phi):
    """Return (sin, cos) of ball b's psi_b = theta + phi within a step.

    (sin, cos) of ball b's psi_b = theta + phi: its step-start values ``psi[b]`` turned by the
    rotor's (st, ct) and by its own phi - phi_b0 to third order (:func:`mis_fast_solve`).
    """
    sr = psi[b, 1] * ct + psi[b, 2] * st
    cr = psi[b, 2] * ct - psi[b, 1] * st
    d = phi - psi[b, 0]
    d2 = 1.0 - 0.5 * d * d
    return sr * d2 + cr * d, cr * d2 - sr * d


@kernel
def apart_substeps(y, n, reach, pairs, ref, h, left):
    """Return how many of the ``left`` fast sub-steps may be taken as one.

    How many of the ``left`` fast sub-steps of h from y :func:`mis_fast_solve` may take as one
    RK4 step: 1 while a neighbour pair touches, else as many as keep every pair apart by
    MIS_APART_MARGIN times its closing at its present rate (no contact force can act within
    them; the fast part is then as smooth as the slow one).
    """
    N = PHI + n
    soonest = left * h * MIS_APART_MARGIN
    for p in range(pairs.shape[0]):
        i = pairs[p, 0]
        j = pairs[p, 1]
        half = 0.5 * (y[PHI + j] - y[PHI + i] - ref[p, 0])
        ah = abs(half)
        if ah < reach:
            return 1                            # touching (the reach of the Hertz law)
        # the half-angle closes at |d half/dt| towards reach; contact when it gets there
        closing = -0.5 * (y[N + PHI + j] - y[N + PHI + i]) * (1.0 if half >= 0.0 else -1.0)
        if closing > 0.0:
            time = (ah - reach) / closing
            if time < soonest:
                soonest = time
    merged = int(soonest / (h * MIS_APART_MARGIN))
    if merged < 1:
        return 1
    return merged if merged < left else left


@kernel
def mis_fast_solve(t0, m, h, y, n, P, fast, trace, rows):
    """Take m RK4 sub-steps of h of the multirate step's fast part from (t0, y), y in place.

    The fast part of :func:`abb_ros.model.dynamics.kernels.multirate.mis_contact_step`: q' = q-dot,
    q-dot' = g + C0 Qc + Jv (phi' - v0); while no pair of balls touches or can touch soon,
    several of them as one (:func:`apart_substeps`: the fast part is then free of contact
    forces). Rows of ``trace`` from ``rows`` on, one per (merged) sub-step; returns the next
    row. (One function with its right-hand side inline: a sub-step is a few hundred flops, a
    kernel call per stage would cost as much.)

    Qc: the contact forces of the neighbour pairs (:func:`pair_state`, :func:`hertz_force`;
    reach = asin(r / R), the half-angle of contact; the half-angles' sines from the step's
    reference ``ref`` by :func:`sincos_near`). C0 Qc: the accelerations they cause through the
    coupled system, ``inv`` = 1 / m R^2 (ball elimination), Ainv the inverse of the eliminated
    deck rows at the step's start: deck u = Ainv (-inv W Qc), ball b (Qc_b - B_b u) inv, with W
    and B at the present angles psi_b = theta + phi_b (``psi``: rows [phi_b, sin psi_b, cos
    psi_b] of the step's start and [theta]; the rotor's turn by :func:`sincos_near`, the ball's
    own, at most ~1e-2 within a step, to third order; R, r, inv include the rolling balls'
    spin). Jv (phi' - v0): the change of the balls' Coriolis, centrifugal and drag terms with
    their rates since the step's start
    (:func:`abb_ros.model.dynamics.kernels.multirate.velocity_coupling`), applied in its factored
    form: the deck rows of Jv, then the ball rows as -inv (B s) through ``Bs`` (n, 3; columns 0, 1,
    5 of the step's start's B) plus the balls' own drag. k (4, 2N), yt (2N): stage buffers; Qc
    (n), sc (2, n: the balls' sin, cos psi_b at a stage) scratch. All of these are the fields
    of ``fast`` (:class:`FastPart`).
    """
    reach, inv, pairs, ref, Ainv = fast.reach, fast.inv, fast.pairs, fast.ref, fast.Ainv
    psi, Jv, Bs, v0, g, Qc, sc = fast.psi, fast.Jv, fast.Bs, fast.v0, fast.g, fast.Qc, fast.sc
    k, yt = fast.k, fast.yt
    N = PHI + n
    n2 = 2 * N
    R, r = P[P_R], P[P_R_BALL]
    K = contact_stiffness(P)
    chi = P[P_CONTACT_DAMPING]
    mr = P[P_m] * R
    mr2 = mr * R - spin_coupling(P)
    inv_d = inv * P[P_DRAG]
    s = 0
    while s < m:
        merged = apart_substeps(y, n, reach, pairs, ref, h, m - s)
        hs = merged * h
        for stage in range(4):
            if stage == 0:
                for i in range(n2):
                    yt[i] = y[i]
            else:
                rk4_stage_point(y, hs if stage == 3 else 0.5 * hs, k[stage - 1], yt)
            dy = k[stage]
            for i in range(n):
                Qc[i] = 0.0
            touching = False
            for p in range(pairs.shape[0]):
                i = pairs[p, 0]
                j = pairs[p, 1]
                half = 0.5 * (yt[PHI + j] - yt[PHI + i] - ref[p, 0])
                if abs(half) >= reach:
                    continue                    # apart
                sh, ch = sincos_near(ref[p, 1], ref[p, 2], ref[p, 3], half - ref[p, 1])
                lever = R * ch if half >= 0.0 else -R * ch
                delta = 2.0 * r - 2.0 * R * abs(sh)
                if delta <= 0.0:
                    continue
                force, _ = hertz_force(K, chi, delta,
                                       -lever * (yt[N + PHI + j] - yt[N + PHI + i]))
                Qc[j] += force * lever
                Qc[i] -= force * lever
                touching = True
            for i in range(N):
                dy[i] = yt[N + i]
                dy[N + i] = g[i]
            # Jv (phi' - v0), Jv of rank 3 in the ball rows (velocity_coupling): the deck's
            # part s, the balls' -inv (B s) and their own drag -inv D (phi' - v0)
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            s3 = 0.0
            s4 = 0.0
            s5 = 0.0
            for b in range(n):
                dv = yt[N + PHI + b] - v0[b]
                s0 += Jv[DECK, b] * dv
                s1 += Jv[DECK + 1, b] * dv
                s2 += Jv[DECK + 2, b] * dv
                s3 += Jv[DECK + 3, b] * dv
                s4 += Jv[DECK + 4, b] * dv
                s5 += Jv[DECK + 5, b] * dv
                dy[N + PHI + b] -= inv_d * dv
            dy[N + DECK] += s0
            dy[N + DECK + 1] += s1
            dy[N + DECK + 2] += s2
            dy[N + DECK + 3] += s3
            dy[N + DECK + 4] += s4
            dy[N + DECK + 5] += s5
            for c in range(n):
                dy[N + PHI + c] -= inv * (Bs[c, 0] * s0 + Bs[c, 1] * s1 + Bs[c, 2] * s5)
            if not touching:
                continue
            al, be, ga = yt[DECK + 3], yt[DECK + 4], yt[DECK + 5]
            st, ct = sincos_near(0.0, 0.0, 1.0, yt[THETA] - psi[n, 0])     # the rotor's turn
            w0 = 0.0
            w1 = 0.0
            w2 = 0.0
            w5 = 0.0
            for b in range(n):
                sb, cb = ball_sincos(psi, st, ct, b, yt[PHI + b])
                sc[0, b] = sb
                sc[1, b] = cb
                q = -inv * Qc[b]
                if q != 0.0:                    # -inv W Qc (W of assemble at yt)
                    w0 -= mr * (sb + ga * cb) * q
                    w1 += mr * (cb - ga * sb) * q
                    w2 += mr * (al * cb + be * sb) * q
                    w5 += mr2 * q
            w3 = be * w5
            u0 = 0.0
            u1 = 0.0
            u5 = 0.0
            for row in range(6):
                ur = (Ainv[row, 0] * w0 + Ainv[row, 1] * w1 + Ainv[row, 2] * w2
                      + Ainv[row, 3] * w3 + Ainv[row, 5] * w5)
                dy[N + DECK + row] += ur
                if row == 0:
                    u0 = ur
                elif row == 1:
                    u1 = ur
                elif row == 5:
                    u5 = ur
            for b in range(n):                  # inv (Qc - B u) (B of assemble at yt)
                dy[N + PHI + b] += inv * (Qc[b] + mr * sc[0, b] * u0 - mr * sc[1, b] * u1
                                          - mr2 * u5)
        rk4_combine(y, hs, k[0], k[1], k[2], k[3], y)
        if rows < trace.shape[0]:
            trace[rows, 0] = t0 + s * h
            trace[rows, 1] = hs
            for i in range(n2):
                trace[rows, 2 + i] = y[i]
        rows += 1
        s += merged
    return rows

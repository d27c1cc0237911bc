"""Rolling resistance of the balls on the race: Coulomb's law with a Karnopp stick band.

A ball rolling on the race feels a resisting torque mu N about its contact (N: its
centrifugal load), a generalized force on its row of Eq. (24) of at most
:func:`rolling_threshold`. Slipping balls get that force against their motion; stuck balls
the force that keeps them stuck (solved with the deck, :func:`accel_rolling`). Switched on by
``rolling_mu`` (docs/ball_size_contact_rolling.md); the regime switches are located in time by
:mod:`abb_ros.model.dynamics.kernels.rolling_events`.
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics.kernels.ball_size import ball_inertia
from abb_ros.model.dynamics.kernels.eom import assemble, solve_deck
from abb_ros.model.dynamics.kernels.layout import (
    P_R,
    P_R_BALL,
    P_ROLLING_MU,
    P_STICK_RATE,
    P_m,
    kernel,
)
from abb_ros.model.dynamics.kernels.spindle import spindle_accel
from abb_ros.model.dynamics.state import DECK, PHI, THETA

STICK_TIME = 1.0e-3
"""A stuck ball's residual rate phi_i' (inside the stick band) decays with this time [s]."""


@kernel
def rolling_threshold(y, n, P, b):
    """Return the largest rolling-resistance generalized force on ball b [N m].

    The torque mu N about the contact, N = m R psi_b'^2 the centrifugal load on the race
    (first order), as a force mu N / r at the centre, times R.
    """
    N = PHI + n
    psid = y[N + THETA] + y[N + PHI + b]
    R = P[P_R]
    return P[P_ROLLING_MU] * P[P_m] * R * psid * psid / P[P_R_BALL] * R


@kernel
def accel_rolling(y, n, P, mR2, qdd, solver, mode, frozen):
    """Fill qdd (deck and balls) with q'' under rolling resistance; return the margin.

    Rolling resistance is Coulomb's law with a Karnopp stick band, acting on the rows that
    ``solver`` holds (assembled, the balls not eliminated).

    Band: |phi_b'| < max(rolling_stick_rate, Qmax_b / (m_eff R^2) STICK_TIME), i.e. speeds
    the rolling resistance alone would take away within STICK_TIME count as rest (a slipping
    ball cannot jump across the band in one step of dt <= STICK_TIME; a narrower band makes
    it chatter around zero speed). Outside the band the ball slips: Qf_b = -Qmax_b
    sign(phi_b'). Inside it the ball sticks: phi_b'' = -phi_b' / STICK_TIME, and Qf_b is
    whatever force that takes (solved with the deck, all balls coupled) while |Qf_b| <= Qmax_b;
    where it would exceed Qmax_b the ball breaks free with Qf_b = Qmax_b sign(Qf_b), and the
    rest are solved again (at most n + 1 solves). ``solver.Qf`` receives the forces.

    Regimes, one per ball in ``mode``: 0 stuck, +-1 slipping outside the band, +-2 broken
    free inside it (Qf_b = sign(mode_b) Qmax_b). ``frozen`` False: the regimes of the state,
    written to ``mode``; True: ``mode`` is kept, each regime's law continued smoothly past its
    boundary (event-located switching,
    :func:`abb_ros.model.dynamics.kernels.rolling_events.rolling_substep`). Returns the switching
    function :func:`rolling_margin` of the regimes.
    """
    A, W, f, B, fb, u, Qf = solver.A, solver.W, solver.f, solver.B, solver.fb, solver.u, solver.Qf
    N = PHI + n
    A0 = A.copy()
    f0 = f.copy()
    inv = 1.0 / mR2
    Qmax = np.empty(n)
    band = np.empty(n)
    target = np.empty(n)
    for b in range(n):
        rate = y[N + PHI + b]
        Qmax[b] = rolling_threshold(y, n, P, b)
        # the band: rolling_stick_rate, or the speed the rolling resistance alone takes away
        # in STICK_TIME if larger (so that a step of dt <= STICK_TIME cannot jump across it)
        band[b] = max(P[P_STICK_RATE], Qmax[b] * inv * STICK_TIME)
        target[b] = -rate / STICK_TIME
        if not frozen:
            if abs(rate) < band[b]:
                mode[b] = 0.0
            else:
                mode[b] = -1.0 if rate > 0.0 else 1.0
        Qf[b] = 0.0 if mode[b] == 0.0 else math.copysign(Qmax[b], mode[b])
    for _ in range(n + 1):
        for i in range(6):
            f[i] = f0[i]
            for j in range(6):
                A[i, j] = A0[i, j]
        for i in range(6):
            for b in range(n):
                if mode[b] == 0.0:
                    f[i] -= W[i, b] * target[b]
                else:
                    w = W[i, b] * inv
                    A[i, 0] -= w * B[b, 0]
                    A[i, 1] -= w * B[b, 1]
                    A[i, 5] -= w * B[b, 5]
                    f[i] -= w * (fb[b] + Qf[b])
        solve_deck(A, f, u)
        released = False
        for b in range(n):
            if mode[b] == 0.0:
                need = mR2 * target[b] - fb[b]
                for j in range(6):
                    need += B[b, j] * u[j]
                if not frozen and abs(need) > Qmax[b]:
                    mode[b] = 2.0 if need > 0.0 else -2.0
                    Qf[b] = math.copysign(Qmax[b], need)
                    released = True
                else:
                    Qf[b] = need
        if not released:
            break
    for i in range(6):
        qdd[DECK + i] = u[i]
    for b in range(n):
        if mode[b] == 0.0:
            qdd[PHI + b] = target[b]
        else:
            acc = fb[b] + Qf[b]
            for j in range(6):
                acc -= B[b, j] * u[j]
            qdd[PHI + b] = acc * inv
    return rolling_margin(y, n, mode, Qmax, band, Qf, qdd, mR2)


@kernel
def rolling_margin(y, n, mode, Qmax, band, Qf, qdd, mR2):
    """Return the switching function of the rolling regimes ``mode`` at y.

    With the forces Qf and accelerations qdd of the regimes: the least over the balls of a
    dimensionless margin, >= 0 while each stays in its regime. Stuck: inside the band (1 -
    |phi'| / band) and holding (1 - |Qf| / Qmax); slipping: outside the band on its side
    (-sign(mode) phi' / band - 1); broken free: still short of the stuck acceleration -phi' /
    STICK_TIME in the direction of its force (sign(mode) (-phi' / STICK_TIME - phi'') m R^2 /
    Qmax).
    """
    N = PHI + n
    margin = math.inf
    for b in range(n):
        rate = y[N + PHI + b]
        scale = Qmax[b] if Qmax[b] > 0.0 else 1.0
        if mode[b] == 0.0:
            g = min(1.0 - abs(rate) / band[b], 1.0 - abs(Qf[b]) / scale)
        elif abs(mode[b]) == 1.0:
            g = -mode[b] * rate / band[b] - 1.0
        else:
            g = math.copysign(mR2 / scale, mode[b]) * (-rate / STICK_TIME - qdd[PHI + b])
        if g < margin:
            margin = g
    return margin


@kernel
def rolling_deriv(t, y, n, P, S, mode, frozen, dy, solver):
    """Fill dy with y' at (t, y) under rolling resistance; return the switching function.

    A speed-driven spindle; the regimes ``mode`` determined (``frozen`` False) or kept
    (True), the forces into ``solver.Qf`` (:func:`accel_rolling`).
    """
    N = PHI + n
    qdd = solver.qdd
    thdd = spindle_accel(t, y[N + THETA], S)
    assemble(y, n, P, thdd, solver.A, solver.W, solver.f, solver.B, solver.fb)
    margin = accel_rolling(y, n, P, ball_inertia(P), qdd, solver, mode, frozen)
    qdd[THETA] = thdd
    for i in range(N):
        dy[i] = y[N + i]
        dy[N + i] = qdd[i]
    return margin

"""The model's right-hand side: q'' and y' = [q', q''] at (t, y), and the balls' forces.

:func:`accel` picks the equations that hold: the rows of Eqs. (18)-(24) for a prescribed
theta'' (:mod:`abb_ros.model.dynamics.kernels.eom`), with rolling resistance
(:mod:`abb_ros.model.dynamics.kernels.rolling_resistance`), or with theta free in torque mode
(:mod:`abb_ros.model.dynamics.kernels.torque`).
"""

from __future__ import annotations

import numpy as np

from abb_ros.model.dynamics.kernels.ball_size import ball_inertia
from abb_ros.model.dynamics.kernels.contact import contact_forces
from abb_ros.model.dynamics.kernels.eom import (
    add_offsets,
    assemble,
    assemble_rows,
    eliminate_balls,
    solve_deck,
)
from abb_ros.model.dynamics.kernels.layout import (
    P_BALL_ROTATION,
    P_CONTACT_E,
    P_ROLLING_MU,
    S_MODE,
    SPINDLE_TORQUE,
    kernel,
    solver_scratch,
)
from abb_ros.model.dynamics.kernels.rolling_resistance import accel_rolling, rolling_deriv
from abb_ros.model.dynamics.kernels.spindle import spindle_accel
from abb_ros.model.dynamics.kernels.torque import accel_free_theta
from abb_ros.model.dynamics.state import DECK, PHI, THETA


@kernel(inline=True)
def accel(t, y, n, P, S, qdd, solver):
    """Fill qdd with q'' at (t, y); ``solver`` is the scratch (:class:`Solver`).

    Eliminate the ball accelerations (their block is m R^2 I: Schur complement), solve the
    deck (:func:`abb_ros.model.dynamics.kernels.eom.solve_deck`), then back-substitute the balls.
    """
    if S[S_MODE] == SPINDLE_TORQUE:
        accel_free_theta(t, y, n, P, S, qdd, solver)
        return
    N = PHI + n
    thdd = spindle_accel(t, y[N + THETA], S)
    assemble(y, n, P, thdd, solver.A, solver.W, solver.f, solver.B, solver.fb)
    mR2 = ball_inertia(P)
    if P[P_ROLLING_MU] > 0.0 and n > 0:
        mode = np.empty(n)
        accel_rolling(y, n, P, mR2, qdd, solver, mode, False)
        qdd[THETA] = thdd
        return
    solve_rows(n, mR2, thdd, qdd, solver)


@kernel(inline=True)
def solve_rows(n, mR2, thdd, qdd, solver):
    """Fill qdd from the rows in ``solver`` (balls' block m R^2 = ``mR2``, theta'' = ``thdd``)."""
    A, W, f, B, fb, u = solver.A, solver.W, solver.f, solver.B, solver.fb, solver.u
    inv = 1.0 / mR2
    eliminate_balls(n, inv, A, W, f, B, fb)
    solve_deck(A, f, u)
    qdd[THETA] = thdd
    for i in range(6):
        qdd[DECK + i] = u[i]
    for b in range(n):
        acc = fb[b]
        for j in range(6):
            acc -= B[b, j] * u[j]
        qdd[PHI + b] = acc * inv


@kernel(inline=True)
def on_paper(n, P, S):
    """Return whether only rigid point-mass terms act (:func:`paper_deriv` applies).

    A speed profile and point-mass balls without rolling resistance or contact: the terms of
    Eqs. (18)-(24), with the heights and the leaning rotor axis where they are set
    (docs/equations.md F4, F6; zero, exactly the paper's rows).
    """
    return (S[S_MODE] != SPINDLE_TORQUE and P[P_BALL_ROTATION] == 0.0
            and not (P[P_ROLLING_MU] > 0.0 and n > 0) and not (P[P_CONTACT_E] > 0.0 and n > 1))


@kernel
def paper_deriv(t, y, n, P, S, dy, solver):
    """:func:`deriv` where :func:`on_paper` holds: the rows assembled in place and solved.

    A call per stage of :func:`~.stepper.paper_step`. :func:`deriv` compiled into its caller
    makes numba count references to the dozen arrays it passes on at every evaluation
    (atomic operations: about 40 % of a tight loop of steps under perf); this call sheds most
    of them.
    """
    N = PHI + n
    qdd = solver.qdd
    thdd = spindle_accel(t, y[N + THETA], S)
    assemble_rows(y, n, P, thdd, solver.A, solver.W, solver.f, solver.B, solver.fb)
    add_offsets(y, n, P, thdd, solver.A, solver.W, solver.f, solver.B)
    solve_rows(n, ball_inertia(P), thdd, qdd, solver)
    for i in range(N):
        dy[i] = y[N + i]
        dy[N + i] = qdd[i]


@kernel
def accel_rows(ys, t0, dt, steps, n, P, S, qdds, solver):
    """Fill each row ``qdds[j]`` with :func:`accel` at the state ``ys[j]`` of step ``steps[j]``.

    The time of row j is t0 + steps[j] dt, as :meth:`Simulation.t` computes it.
    """
    for j in range(ys.shape[0]):
        accel(t0 + steps[j] * dt, ys[j], n, P, S, qdds[j], solver)


@kernel(inline=True)
def deriv(t, y, n, P, S, dy, solver):
    """Fill dy with y' = [q', q''] at (t, y) (q'' into ``solver.qdd`` on the way)."""
    N = PHI + n
    qdd = solver.qdd
    accel(t, y, n, P, S, qdd, solver)
    for i in range(N):
        dy[i] = y[N + i]
        dy[N + i] = qdd[i]


@kernel
def ball_forces(t, y, n, P, S, Qc, Qf):
    """Fill the balls' contact forces Qc and rolling-resistance forces Qf at (t, y).

    Diagnostics of the ball rows; returns (contact energy [J], contact damping power [W]).
    """
    N = PHI + n
    solver = solver_scratch(n)
    energy = 0.0
    power = 0.0
    for i in range(n):
        Qc[i] = 0.0
        Qf[i] = 0.0
    if P[P_CONTACT_E] > 0.0 and n > 1:
        energy, power = contact_forces(y, n, P, Qc)
    if P[P_ROLLING_MU] > 0.0 and n > 0:
        mode = np.empty(n)
        rolling_deriv(t, y, n, P, S, mode, False, np.empty(2 * N), solver)
        for i in range(n):
            Qf[i] = solver.Qf[i]
    return energy, power

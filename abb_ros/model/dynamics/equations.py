"""Nonlinear 3D equations of motion, Eqs. (18)-(24), generalised to a varying spindle speed.

State convention (:mod:`abb_ros.model.dynamics.state`, used throughout abb_ros): generalised
coordinates ``q = [theta, X, Y, Z, alpha, beta, gamma, phi_1..phi_n]`` (N = 7 + n) and the state
``y = [q, q']`` of size 2N. ``theta`` is the rotor angle relative to the deck (the motor's
stator is fixed on the deck); it replaces the paper's ``omega t``, so ``y[N] = theta' =
omega`` is the actual spindle speed. theta is prescribed (the motor torque does work on
theta only), so it has no equation of its own: its acceleration theta'' comes from the
spindle profile (:mod:`abb_ros.model.dynamics.integrate`).

Arrangement: the (6 + n) equations are assembled as ``M(q, t) q'' = f(q, q', t)`` by
:func:`abb_ros.model.dynamics.kernels.eom.assemble` (one implementation, compiled and pure Python).
The ball block of M is ``m R^2 I`` (Eq. 24), so the ball accelerations are eliminated
analytically (Schur complement): each evaluation is an O(n) assembly plus one 6 x 6 solve,
cheaper than solving the (6 + n) system and exact, and the cost grows linearly with n.

Generalisation to theta(t) (Lagrange's equations with theta(t) in place of omega t; the
sympy test derives them independently from Eqs. 11, 13, 16): every ball angle enters as
psi_i = phi_i + theta with psi_i' = phi_i' + omega and psi_i'' = phi_i'' + theta''; the
mass centre G of the rotor enters exactly like a ball of mass M at radius eps and angle
theta (psi'' = theta''); the rotor's spin inertia adds J_z theta'' to the gamma equation
(23) and J_z theta'' beta to the alpha equation (21) (from d/dt of dT/dalpha' = J_z omega
beta). With theta'' = 0 the equations are exactly Eqs. (18)-(24).

Typos of the printed equations, resolved against the energies:

- Eqs. (21), (23): 'Mpd' is M_P d.
- Eqs. (6)-(8): 'cos psi' is cos gamma (the Euler product T_beta T_alpha T_gamma), and the
  i-component's '+Z cos alpha sin beta' is -Z cos alpha sin beta (entry (1,3) of that product);
  neither changes Eqs. (18)-(24), which follow from the inertial velocities.
- Eqs. (21), (22) take J_x, J_y about the deck axes: exact for an axisymmetric rotor only, so
  the parameters require J_x = J_y (docs/equations.md, F1).
- Eq. (20): the right-hand side M eps omega^2 (alpha sin - beta cos) is the rotor G's
  psi'^2 terms; here they sit with the ball terms of the same form (same sign).
- Eq. (21): the term m R^2 beta sum phi_i'' generalises to beta (sum_j mu_j r_j^2 psi_j''
  + J_z theta''); the printed equation has only the balls' part because theta'' = 0.
- Eq. (33) prints X', Y' where Eq. (24) has X'', Y'': the ball equation involves the
  accelerations (see :mod:`abb_ros.model.stability.linear`).
"""

from __future__ import annotations

import numpy as np

from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.state import StateLayout, n_coords
from abb_ros.model.parameters.params import DriveParams

__all__ = ['lagrange_residual', 'accelerations']


def solver_buffers(n: int) -> kernels.Solver:
    """Return the kernels' scratch for n balls (:class:`abb_ros.model.dynamics.kernels.Solver`)."""
    return kernels.solver_scratch(n)


def _check(params: DriveParams, y) -> np.ndarray:
    y = np.ascontiguousarray(y, dtype=float)
    if y.shape != (2 * n_coords(params.n_balls),):
        raise ValueError(f'state y must have shape ({2 * n_coords(params.n_balls)},) for '
                         f'{params.n_balls} balls, got {y.shape}')
    return y


def lagrange_residual(params: DriveParams, y, qdd, kern=None) -> np.ndarray:
    """Residuals of Eqs. (18)-(24) generalised to theta(t), shape (6 + n,).

    Order [X, Y, Z, alpha, beta, gamma, phi_1..phi_n]; each is the left-hand side minus
    the right-hand side of the paper's equation (Lagrange's d/dt dT/dq' - dT/dq + dV/dq
    + dF/dq'). ``qdd`` has shape (N,) and includes theta'' at index 0.
    """
    kern = kern or kernels.JIT
    y = _check(params, y)
    qdd = np.asarray(qdd, dtype=float)
    n = params.n_balls
    solver = solver_buffers(n)
    A, W, f, B, fb = solver.A, solver.W, solver.f, solver.B, solver.fb
    kern.assemble(y, n, kernels.pack_params(params), float(qdd[0]), A, W, f, B, fb)
    layout = StateLayout(n)
    u = qdd[layout.deck_slice]
    phidd = qdd[layout.phi_slice]
    mR2 = np.array([m * R ** 2 for m, R, _ in params.per_ball()])
    mR2 *= 1.4 if params.ball_rotation else 1.0         # 7/5: rolling balls (one race only)
    deck = A @ u + W[:, :n] @ phidd - f
    balls = B[:n] @ u + mR2 * phidd - fb[:n]
    return np.concatenate([deck, balls])


def accelerations(params: DriveParams, y, t: float = 0.0, spindle=None, kern=None
                  ) -> np.ndarray:
    """Return q'' at state y and time t, shape (N,).

    ``spindle`` is a packed profile (see :mod:`abb_ros.model.dynamics.kernels.layout`), default
    constant speed (theta'' = 0).
    """
    kern = kern or kernels.JIT
    y = _check(params, y)
    n = params.n_balls
    S = np.zeros(kernels.N_SPINDLE) if spindle is None else np.asarray(spindle, dtype=float)
    qdd = np.empty(n_coords(n))
    kern.accel(float(t), y, n, kernels.pack_params(params), S, qdd, solver_buffers(n))
    return qdd


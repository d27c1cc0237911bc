"""The in-plane monodromy of n balls from a system of six coordinates, exactly.

In the in-plane equations (27), (28), (32), (33) the ball angles reach the deck rows only
through sum_i phi_i sin(phi*_i + tau), sum_i phi_i cos(phi*_i + tau) and sum_i phi_i (with
their rates and accelerations), that is through the projection of phi onto
span{sin phi*, cos phi*, 1}; and the ball-ball blocks of M, C and K are m R^2 I, D I and 0
(each ball's block a multiple of the identity). Take an orthonormal basis [Q, Q_perp] of R^n
with range Q containing that span (Q, n x 3, from a QR factorisation: it contains the span
whatever its rank). In the coordinates [X, Y, gamma, Q^T phi, Q_perp^T phi] the equations
split exactly into

- the deck and the three ball coordinates Q^T phi: the projected system T^T M T, T^T C T,
  T^T K T with T = blockdiag(I_3, Q), nq = 6 whatever n (:func:`project`);
- n - 3 copies of m R^2 psi'' + D psi' = 0 (per radian of tau: psi'' = -a psi', a = D /
  (omega m R^2)), coupled to nothing.

A Runge-Kutta method commutes with a constant change of variables, so the RK4 monodromy of the
whole system is the same change of variables applied to blockdiag(Phi_reduced, the psi blocks): its
multipliers are the reduced system's and, n - 3 times each, 1 (psi itself, a direction of the
balanced family: removed as neutral, :mod:`abb_ros.model.stability.family`) and rho = R(-a h)^N,
with R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24 the RK4 stability polynomial and N steps of h
(:func:`complement_multiplier`). The steps are the whole system's: its decay estimate is the larger
of the reduced system's and a (:func:`complement_decay`). So the transverse multipliers equal the
whole-system kernel's to round-off (test_floquet_reduction: 1e-9), while one RK4 step costs the
work of six coordinates instead of 3 + n. The family's tangent directions inside the reduced
coordinates are null(J Q) (J of Eq. 26, whose rows sin and cos lie in range Q), and the n - 3
directions Q_perp are tangent too (:func:`reduced_frame`).
"""

from __future__ import annotations

import numpy as np

from abb_ros.model.stability.family import eq26_jacobian, null_frame

__all__ = ['REDUCED_BALLS', 'reduces', 'ball_basis', 'project', 'complement_decay',
           'complement_multiplier', 'reduced_frame']

REDUCED_BALLS = 3
"""Ball coordinates kept: the dimension of span{sin phi*, cos phi*, 1}. Only n > 3 reduces."""


def reduces(n: int) -> bool:
    """Return True when n balls have ball directions that decouple (n > REDUCED_BALLS)."""
    return n > REDUCED_BALLS


def ball_basis(phi) -> np.ndarray:
    """Return Q, shape (B, n, 3), orthonormal columns whose range holds sin phi, cos phi, 1."""
    phi = np.asarray(phi, dtype=float)
    A = np.stack([np.ones_like(phi), np.sin(phi), np.cos(phi)], axis=-1)
    return np.linalg.qr(A)[0]


def project(Mh, Ch, Kh, Q):
    """Return the harmonics of the reduced system, T^T H T with T = blockdiag(I_3, Q).

    Mh, Ch, Kh : (B, H, 3 + n, 3 + n) in-plane harmonics; Q : (B, n, 3). Returns three arrays
    of shape (B, H, 6, 6).
    """
    B, n = Q.shape[0], Q.shape[1]
    T = np.zeros((B, 1, 3 + n, 3 + REDUCED_BALLS))
    T[:, 0, :3, :3] = np.eye(3)
    T[:, 0, 3:, 3:] = Q
    Tt = np.swapaxes(T, -1, -2)
    return tuple(np.ascontiguousarray(Tt @ H @ T) for H in (Mh, Ch, Kh))


def complement_decay(p, omega) -> np.ndarray:
    """Return a = D / (omega m R^2) [1/rad of tau], the decay rate of each decoupled direction."""
    return np.asarray(p.D, dtype=float) / (np.asarray(omega, dtype=float) * p.m * p.R ** 2)


def complement_multiplier(a, tau_end, nsteps) -> np.ndarray:
    """Return |R(-a h)|^N, the RK4 multiplier of psi' after N = nsteps steps of h = tau_end / N."""
    z = -np.asarray(a, dtype=float) * np.asarray(tau_end, dtype=float) / nsteps
    r = 1.0 + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0)))
    return np.abs(r) ** nsteps


def reduced_frame(phi, Q):
    """Return (U (B, 3, 3), k (B,)): the family's frame in the reduced ball coordinates.

    U is orthogonal, its last k columns spanning null(J Q) (the tangent directions of the
    balanced family within range Q); the whole family has k + n - 3 tangent directions.
    """
    return null_frame(eq26_jacobian(phi) @ Q)

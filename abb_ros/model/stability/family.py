"""The family of balanced equilibria of Eq. (26): its tangent space, members and samples.

Eq. (26) is two conditions on n ball angles, F(phi) = [M eps/(m R) + sum cos phi_i,
sum sin phi_i] = 0, with the 2 x n Jacobian::

    J(phi) = [[-sin phi_1 .. -sin phi_n],
              [ cos phi_1 ..  cos phi_n]].

Where J has rank r, the balanced equilibria near phi* form a manifold of dimension n - r: for
n >= 3 (r = 2) a family of dimension n - 2, and for n = 2 at eps = 0 (balls opposite, r = 1)
the rotations. Every tangent direction v (J v = 0) with X = Y = gamma = 0 and zero rates is an
equilibrium of the linearised in-plane equations (33) as well (their ball terms enter the deck
rows only through J), so the monodromy maps it to itself: a Floquet multiplier exactly 1 that
says nothing about stability. :mod:`abb_ros.model.stability.floquet` removes these directions;
this module gives them (:func:`tangent_frame`), the member of the family nearest a given
configuration (:func:`nearest_member`) and a sample of members (:func:`sample_members`).
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics.state import wrap_angle

__all__ = ['RANK_TOL', 'eq26_jacobian', 'tangent_frame', 'neutral_count', 'nearest_member',
           'sample_members', 'min_spacing', 'NEWTON_ITERATIONS']

RANK_TOL = 1e-9
"""A singular value of J below RANK_TOL x the largest one counts as zero. J's singular values
are O(1) (its rows have norms up to sqrt(n)); at the rank-deficient configurations they are
exactly 0 up to round-off (1e-16), and the weakest genuine one met in practice (two balls at
epsbar = 1e-6 of the capacity's edge) is ~1e-3."""

NEWTON_ITERATIONS = 30
"""Most Gauss-Newton steps of :func:`nearest_member` (it converges quadratically: 4-6
steps from within 0.3 rad of the family)."""


def eq26_jacobian(phi) -> np.ndarray:
    """Return the Jacobian J of Eq. (26) at phi [rad], shape (..., 2, n)."""
    phi = np.asarray(phi, dtype=float)
    return np.stack([-np.sin(phi), np.cos(phi)], axis=-2)


def tangent_frame(phi):
    """Return an orthonormal frame of R^n adapted to the family at phi [rad] (shape (..., n)).

    Returns (U, k): U shape (..., n, n) orthogonal, whose last k[...] columns span the tangent
    space null(J) and whose first n - k columns span its complement (the row space of J);
    k = n - rank J, shape phi.shape[:-1].
    """
    phi = np.asarray(phi, dtype=float)
    n = phi.shape[-1]
    J = eq26_jacobian(phi)
    _, s, vh = np.linalg.svd(J, full_matrices=True)
    big = s.max(axis=-1, keepdims=True) if n else np.zeros(phi.shape[:-1] + (1,))
    rank = (s > RANK_TOL * np.maximum(big, 1.0)).sum(axis=-1)
    return np.swapaxes(vh, -1, -2), n - rank


def neutral_count(phi) -> np.ndarray:
    """Return n - rank J(phi), the dimension of the family through phi (int array)."""
    return tangent_frame(phi)[1]


def min_spacing(phi) -> float:
    """Return the smallest angular distance [rad] between two of the angles phi (inf for n < 2)."""
    phi = np.sort(wrap_angle(np.asarray(phi, dtype=float)))
    if phi.size < 2:
        return math.inf
    gaps = np.diff(np.concatenate([phi, phi[:1] + 2 * math.pi]))
    return float(gaps.min())


def _residual(ratio, phi):
    return np.array([ratio + np.cos(phi).sum(), np.sin(phi).sum()])


def nearest_member(ratio: float, phi0, tol: float = 1e-13):
    """Solve Eq. (26) from phi0 by minimum-norm Gauss-Newton steps.

    ``ratio`` = M eps / (m R); phi0 [rad], shape (n,). Each step is the smallest change of
    the angles that zeroes the linearised residual (phi -= J^+ F), so the result is the
    member of the family nearest phi0 to first order in the distance. Returns (phi, residual);
    phi is None when the iteration does not converge to ``tol`` (phi0 too far from any
    balanced configuration, or none exists).
    """
    phi = np.array(phi0, dtype=float)
    res = _residual(ratio, phi)
    for _ in range(NEWTON_ITERATIONS):
        if np.abs(res).max() <= tol * max(phi.size, 1):
            return wrap_angle(phi), float(np.abs(res).max())
        phi = phi - np.linalg.lstsq(eq26_jacobian(phi), res, rcond=None)[0]
        res = _residual(ratio, phi)
    ok = np.abs(res).max() <= tol * max(phi.size, 1)
    return (wrap_angle(phi) if ok else None), float(np.abs(res).max())


def sample_members(ratio: float, n: int, count: int, first=None, spacing: float = 0.0,
                   seed: int = 0) -> np.ndarray:
    """Sample ``count`` members of the family of Eq. (26) for n balls, shape (count, n) [rad].

    ``first`` (a member, e.g. the symmetric fan) is the first row when given; the others are
    random angles (``seed``) projected onto Eq. (26) by :func:`nearest_member`, keeping those
    whose balls are at least ``spacing`` [rad] apart (the contact separation of balls with a
    size). Fewer rows are returned when the members are hard to find (at most 50 count tries).
    """
    rng = np.random.default_rng([seed, n])
    rows = [] if first is None else [np.asarray(first, dtype=float)]
    tries = 0
    while len(rows) < count and tries < 50 * count:
        tries += 1
        phi, _ = nearest_member(ratio, rng.uniform(-math.pi, math.pi, n))
        if phi is not None and min_spacing(phi) >= spacing:
            rows.append(phi)
    return np.array(rows).reshape(len(rows), n)

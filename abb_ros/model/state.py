"""The layout of the state vector ``y = [q, q']``: one definition for all of abb_ros.

Generalised coordinates ``q = [theta, X, Y, Z, alpha, beta, gamma, phi_1..phi_n]`` (N = 7 + n,
:mod:`abb_ros.model.dynamics`) and their rates, so ``y[N] = theta' = omega`` is the spindle
speed. The offsets below are plain integers so the compiled kernels (:mod:`abb_ros.model.kernels`)
index with the same constants; Python code uses :class:`StateLayout`'s named slices and
accessors, which take one state (shape (2N,)) or many (shape (..., 2N)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ['THETA', 'DECK', 'N_DECK', 'ALPHA', 'PHI', 'DECK_NAMES', 'n_coords', 'StateLayout',
           'rbar', 'wrap_angle', 'wrap_degrees']

THETA = 0
"""Index of theta (rotor angle relative to the deck) in q."""

DECK_NAMES = ('X', 'Y', 'Z', 'alpha', 'beta', 'gamma')
"""The deck coordinates, in their order in q: C's translation [m], then Euler angles [rad]."""

DECK = 1
"""Index of X, the first deck coordinate, in q."""

N_DECK = len(DECK_NAMES)

ALPHA = DECK + 3
"""Index of alpha, the first Euler angle (alpha, beta, gamma follow X, Y, Z), in q."""

PHI = DECK + N_DECK
"""Index of phi_1, the first ball angle, in q (= 7)."""


def n_coords(n: int) -> int:
    """N = 7 + n generalised coordinates (theta, 6 deck coordinates, n ball angles)."""
    return PHI + n


def rbar(X, Y, Z, R: float):
    """rbar = sqrt(X^2 + Y^2 + Z^2) / R (Section 5): deck translation over the race radius."""
    return np.sqrt(X ** 2 + Y ** 2 + Z ** 2) / R


def wrap_angle(phi):
    """Angles [rad] wrapped to (-pi, pi]."""
    return math.pi - np.mod(math.pi - np.asarray(phi, dtype=float), 2.0 * math.pi)


def wrap_degrees(phi) -> np.ndarray:
    """Angles [rad] wrapped to (-pi, pi], in degrees."""
    return np.degrees(wrap_angle(phi))


@dataclass(frozen=True)
class StateLayout:
    """Where each coordinate and rate of the drive with ``n`` balls sits in ``y``.

    Slices index the last axis; accessors return views (``y[..., slice]``) or, for the
    scalars theta and omega, ``y[..., index]``.
    """

    n: int

    @property
    def N(self) -> int:
        """Number of generalised coordinates, 7 + n."""
        return n_coords(self.n)

    @property
    def size(self) -> int:
        """Length of y, 2 N."""
        return 2 * self.N

    # ---- indices and slices of y ------------------------------------------------------------
    @property
    def q(self) -> slice:
        return slice(0, self.N)

    @property
    def qd(self) -> slice:
        return slice(self.N, self.size)

    theta_index = THETA
    """theta is y[0]."""

    @property
    def omega_index(self) -> int:
        """omega = theta' is y[N]."""
        return self.N + THETA

    deck_slice = slice(DECK, PHI)
    """[X, Y, Z, alpha, beta, gamma]."""

    translation_slice = slice(DECK, DECK + 3)
    """[X, Y, Z] (m)."""

    @property
    def phi_slice(self) -> slice:
        return slice(PHI, self.N)

    @property
    def deck_rate_slice(self) -> slice:
        return slice(self.N + DECK, self.N + PHI)

    @property
    def phi_rate_slice(self) -> slice:
        return slice(self.N + PHI, self.size)

    def coord_names(self) -> tuple[str, ...]:
        """Names of q: theta, X, Y, Z, alpha, beta, gamma, phi_1..phi_n."""
        return ('theta',) + DECK_NAMES + tuple(f'phi_{i + 1}' for i in range(self.n))

    # ---- accessors ----------------------------------------------------------------------------
    def theta(self, y):
        return np.asarray(y)[..., THETA]

    def omega(self, y):
        """Spindle speed theta' [rad/s]."""
        return np.asarray(y)[..., self.omega_index]

    def deck(self, y) -> np.ndarray:
        """[X, Y, Z, alpha, beta, gamma] (m, rad)."""
        return np.asarray(y)[..., self.deck_slice]

    def translation(self, y) -> np.ndarray:
        """[X, Y, Z] (m)."""
        return np.asarray(y)[..., self.translation_slice]

    def deck_rates(self, y) -> np.ndarray:
        return np.asarray(y)[..., self.deck_rate_slice]

    def phi(self, y) -> np.ndarray:
        """Ball angles phi_1..phi_n relative to the rotor [rad]."""
        return np.asarray(y)[..., self.phi_slice]

    def phi_rates(self, y) -> np.ndarray:
        return np.asarray(y)[..., self.phi_rate_slice]

    def coords(self, y) -> np.ndarray:
        """q (first half of y)."""
        return np.asarray(y)[..., self.q]

    def rates(self, y) -> np.ndarray:
        """q' (second half of y)."""
        return np.asarray(y)[..., self.qd]

    def rbar(self, y, R: float):
        """rbar = sqrt(X^2 + Y^2 + Z^2) / R (Section 5), R the race radius [m]."""
        y = np.asarray(y)
        return rbar(y[..., DECK], y[..., DECK + 1], y[..., DECK + 2], R)

    # ---- construction -------------------------------------------------------------------------
    def pack(self, theta: float = 0.0, deck=(0.0,) * N_DECK, phi=None, omega: float = 0.0,
             deck_rates=(0.0,) * N_DECK, phi_rates=None) -> np.ndarray:
        """A new state y (shape (2N,)); unset ball angles and rates are zero."""
        y = np.zeros(self.size)
        y[THETA] = theta
        y[self.deck_slice] = deck
        if phi is not None:
            y[self.phi_slice] = phi
        y[self.omega_index] = omega
        y[self.deck_rate_slice] = deck_rates
        if phi_rates is not None:
            y[self.phi_rate_slice] = phi_rates
        return y

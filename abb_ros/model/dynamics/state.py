"""The layout of the state vector ``y = [q, q']``: one definition for all of abb_ros.

Generalised coordinates ``q = [theta, X, Y, Z, alpha, beta, gamma, phi_1..phi_n]`` (N = 7 + n,
:mod:`abb_ros.model.dynamics.equations`) and their rates, so ``y[N] = theta' = omega`` is the
spindle speed. The offsets below are plain integers so the compiled kernels
(:mod:`abb_ros.model.dynamics.kernels`) index with the same constants; Python code uses
:class:`StateLayout`'s named slices and accessors, which take one state (shape (2N,)) or many
(shape (..., 2N)).
"""

from __future__ import annotations

import functools
import math

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
    """Return N = 7 + n generalised coordinates (theta, 6 deck coordinates, n ball angles)."""
    return PHI + n


def rbar(X, Y, Z, R: float):
    """Return rbar = sqrt(X^2 + Y^2 + Z^2) / R (Section 5), deck translation over race radius."""
    return np.sqrt(X ** 2 + Y ** 2 + Z ** 2) / R


def wrap_angle(phi):
    """Wrap angles [rad] to (-pi, pi]."""
    return math.pi - np.mod(math.pi - np.asarray(phi, dtype=float), 2.0 * math.pi)


def wrap_degrees(phi) -> np.ndarray:
    """Wrap angles [rad] to (-pi, pi] and return them in degrees."""
    return np.degrees(wrap_angle(phi))


class StateLayout:
    """Where each coordinate and rate of the drive with ``n`` balls sits in ``y``.

    Attributes are indices and slices of the last axis of y; accessors return views
    (``y[..., slice]``) or, for the scalars theta and omega, ``y[..., index]``. Immutable;
    :meth:`of` returns a shared instance per n (for hot paths).
    """

    __slots__ = ('n', 'N', 'size', 'q', 'qd', 'omega_index', 'phi_slice', 'deck_rate_slice',
                 'phi_rate_slice')

    theta_index = THETA
    """theta is y[0]."""

    deck_slice = slice(DECK, PHI)
    """[X, Y, Z, alpha, beta, gamma]."""

    translation_slice = slice(DECK, DECK + 3)
    """[X, Y, Z] (m)."""

    def __init__(self, n: int):
        N = n_coords(n)
        for name, value in (('n', n), ('N', N), ('size', 2 * N), ('q', slice(0, N)),
                            ('qd', slice(N, 2 * N)), ('omega_index', N + THETA),
                            ('phi_slice', slice(PHI, N)),
                            ('deck_rate_slice', slice(N + DECK, N + PHI)),
                            ('phi_rate_slice', slice(N + PHI, 2 * N))):
            object.__setattr__(self, name, value)

    @classmethod
    @functools.lru_cache(maxsize=None)
    def of(cls, n: int) -> StateLayout:
        """Return the layout for n balls, one shared instance per n."""
        return cls(n)

    def __setattr__(self, name, value):
        raise AttributeError('StateLayout is immutable')

    def __eq__(self, other) -> bool:
        return isinstance(other, StateLayout) and other.n == self.n

    def __hash__(self) -> int:
        return hash((StateLayout, self.n))

    def __repr__(self) -> str:
        return f'StateLayout(n={self.n})'

    def coord_names(self) -> tuple[str, ...]:
        """Return the names of q: theta, X, Y, Z, alpha, beta, gamma, phi_1..phi_n."""
        return ('theta',) + DECK_NAMES + tuple(f'phi_{i + 1}' for i in range(self.n))

    # ---- accessors ----------------------------------------------------------------------------
    def theta(self, y):
        """Return the spindle angle theta [rad]."""
        return np.asarray(y)[..., THETA]

    def omega(self, y):
        """Return the spindle speed theta' [rad/s]."""
        return np.asarray(y)[..., self.omega_index]

    def deck(self, y) -> np.ndarray:
        """Return the deck coordinates [X, Y, Z, alpha, beta, gamma] (m, rad)."""
        return np.asarray(y)[..., self.deck_slice]

    def translation(self, y) -> np.ndarray:
        """Return the deck translation [X, Y, Z] (m)."""
        return np.asarray(y)[..., self.translation_slice]

    def deck_rates(self, y) -> np.ndarray:
        """Return the deck rates [X', Y', Z', alpha', beta', gamma'] (m/s, rad/s)."""
        return np.asarray(y)[..., self.deck_rate_slice]

    def phi(self, y) -> np.ndarray:
        """Return the ball angles phi_1..phi_n relative to the rotor [rad]."""
        return np.asarray(y)[..., self.phi_slice]

    def phi_rates(self, y) -> np.ndarray:
        """Return the ball angle rates phi_1'..phi_n' relative to the rotor [rad/s]."""
        return np.asarray(y)[..., self.phi_rate_slice]

    def coords(self, y) -> np.ndarray:
        """Return q (first half of y)."""
        return np.asarray(y)[..., self.q]

    def rates(self, y) -> np.ndarray:
        """Return q' (second half of y)."""
        return np.asarray(y)[..., self.qd]

    def rbar(self, y, R: float):
        """Return rbar = sqrt(X^2 + Y^2 + Z^2) / R (Section 5), R the race radius [m]."""
        y = np.asarray(y)
        return rbar(y[..., DECK], y[..., DECK + 1], y[..., DECK + 2], R)

    # ---- construction -------------------------------------------------------------------------
    def pack(self, theta: float = 0.0, deck=(0.0,) * N_DECK, phi=None, omega: float = 0.0,
             deck_rates=(0.0,) * N_DECK, phi_rates=None) -> np.ndarray:
        """Return a new state y (shape (2N,)); unset ball angles and rates are zero."""
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

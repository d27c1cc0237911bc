"""Where the balls settle when they cannot balance: the locked-ball steady state (Section 5, P1).

Below the translational natural frequency (P1, wbar = 0.8) the balls merge and lock to the
rotor at one angle phi_L. There they feel no mean tangential force over a revolution: with
phi_i' = phi_i'' = theta'' = 0, Eq. (24) leaves

    Q(t) = m R (X'' sin psi - Y'' cos psi) - m R^2 gamma'',     mean of Q over a period = 0,

with psi = omega t + phi_L, and the lock is stable where dQ/dphi < 0. To first order in the
imbalance the deck's response is the harmonic forced response of the constant-coefficient
in-plane system (X, Y, gamma of Eqs. 18, 19, 23) to the rotating imbalance
U = M eps + n m R exp(i phi_L) (rotor plus locked balls); the terms of Eqs. (18)-(23) that
multiply the deck coordinates by the imbalance are second order and dropped here.

Physically: the balls run to where the race is thrown outward, the direction of the whirl
displacement, which lags the TOTAL imbalance by the phase lag delta of the deck's response.
As the locked balls are themselves most of that imbalance (n m R > M eps at P1), they chase
their own contribution: phi_L = arg U(phi_L) - delta, i.e. for small angles
phi_L ~ -delta (M eps + n m R) / (M eps): a lag of a few degrees is amplified several times,
and the balls settle behind G (negative phi), on the imbalance side.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from abb_ros.model.dynamics.state import wrap_angle
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.stability.linear import in_plane_harmonics

__all__ = ['in_plane_matrices_static', 'mean_tangential_force', 'locked_ball_angle']

_SAMPLES = 256  # points per revolution for the mean of Q (exact for the harmonics involved)


def in_plane_matrices_static(params: DriveParams):
    """Return the constant mass, damping, stiffness matrices of the deck's in-plane motion.

    The deck (X, Y, gamma) block of harmonic 0 of the linearised Eqs. (27), (28), (32)
    (abb_ros.model.stability.linear), which does not depend on the ball angles.
    """
    harmonics = in_plane_harmonics(params, 0.0, np.zeros(params.n))
    return tuple(H[0, :3, :3] for H in harmonics)


def mean_tangential_force(params: DriveParams, omega: float, phi_lock: float) -> float:
    """Return the mean of Q [N m] over a revolution on one ball locked at phi_lock (module doc)."""
    p = params
    M, C, K = in_plane_matrices_static(p)
    U = p.M * p.eps + p.n * p.m * p.R * np.exp(1j * phi_lock)
    force = omega ** 2 * np.array([U, -1j * U, 0.0])      # X + i.. as complex amplitudes
    x_hat = np.linalg.solve(K + 1j * omega * C - omega ** 2 * M, force)
    t = np.arange(_SAMPLES) * (2 * np.pi / omega / _SAMPLES)
    e = np.exp(1j * omega * t)
    Xdd, Ydd, Gdd = (np.real(-omega ** 2 * x_hat[i] * e) for i in range(3))
    psi = omega * t + phi_lock
    Q = p.m * p.R * (Xdd * np.sin(psi) - Ydd * np.cos(psi)) - p.m * p.R ** 2 * Gdd
    return float(Q.mean())


def locked_ball_angle(params: DriveParams, omega: float) -> float:
    """Return the stable lock angle phi_L [rad] of merged balls (mean Q = 0, dQ/dphi < 0).

    Raises ValueError if there is none (e.g. n = 0).
    """
    if params.n == 0:
        raise ValueError('no balls (n = 0): no lock angle')
    grid = np.radians(np.arange(-180.0, 181.0, 2.0))
    q = np.array([mean_tangential_force(params, omega, x) for x in grid])
    for i in range(len(grid) - 1):
        if q[i] > 0 >= q[i + 1]:   # Q falls through zero: stable
            root = brentq(lambda x: mean_tangential_force(params, omega, x), grid[i], grid[i + 1],
                          xtol=1e-12)
            return float(wrap_angle(root))
    raise ValueError('no stable locked-ball angle found')

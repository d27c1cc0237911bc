"""Disturbances of the plant's state for tests: a shock to the deck and a disc swap.

Pure numpy: each function returns a new state y = [q, q'] (see
:func:`abb_ros.model.dynamics.initial.initial_state`); the caller puts it into the simulation
between two steps.

Shock (:func:`apply_shock`): an impulse on the deck changes its velocities at once and not its
position. The step is given as the deck twist of ``deck/twist``: velocity of C and angular
velocity Eq. (10), both in deck axes, [m/s] and [rad/s]. The twist is linear in the rates,
(v, w) = L(q) (X', Y', Z', alpha', beta', gamma'), with L built from
:func:`abb_ros.model.sensors.imu.deck_velocity`; the rates get L^-1 times the step, so the twist
jumps by exactly the step (to rounding). L is invertible away from cos(alpha) = 0.

Disc swap (:func:`swap_disc`): a new disc puts the imbalance G at an angle ``delta`` from the
old one's, the rotor and the balls not moving. In the kernel's convention
(:func:`abb_ros.model.dynamics.kernels.eom.assemble`) G is at angle theta and ball i at theta +
phi_i, with phi_i measured from G; so the same physical configuration with G moved by delta is
theta + delta, phi_i - delta (rates unchanged). The new eccentricity is a parameter
(``DriveParams.eps``). The balls then settle towards the new disc's phi_star.
"""

from __future__ import annotations

import numpy as np

from abb_ros.model.dynamics.equations import n_coords
from abb_ros.model.sensors.imu import deck_velocity

__all__ = ['deck_twist_matrix', 'apply_shock', 'swap_disc']


def deck_twist_matrix(y: np.ndarray, n: int) -> np.ndarray:
    """Return L(q), shape (6, 6), the map from the deck's coordinate rates to its twist.

    The twist (v, w) is in deck axes; the rates are (X', Y', Z', alpha', beta', gamma').
    """
    N = n_coords(n)
    q = y[:N]
    columns = []
    for j in range(6):
        qd = np.zeros(N)
        qd[1 + j] = 1.0
        v, w = deck_velocity(q, qd)
        columns.append(np.concatenate([v, w]))
    return np.array(columns).T


def apply_shock(y: np.ndarray, n: int, twist_step) -> np.ndarray:
    """Return the state just after an impulsive shock to the deck.

    The deck twist is stepped by ``twist_step`` (vx, vy, vz [m/s], wx, wy, wz [rad/s], deck
    axes); positions are unchanged.
    """
    step = np.asarray(twist_step, dtype=float)
    if step.shape != (6,):
        raise ValueError(f'twist_step: 6 values, got shape {step.shape}')
    N = n_coords(n)
    out = np.array(y, dtype=float)
    out[N + 1:N + 7] += np.linalg.solve(deck_twist_matrix(y, n), step)
    return out


def swap_disc(y: np.ndarray, n: int, delta: float) -> np.ndarray:
    """Return the state re-expressed for an imbalance moved by ``delta`` [rad] in the rotor.

    theta + delta, phi_i - delta; nothing moves.
    """
    N = n_coords(n)
    out = np.array(y, dtype=float)
    out[0] += delta
    out[7:N] -= delta
    return out

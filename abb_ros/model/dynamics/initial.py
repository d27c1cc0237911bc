"""The initial state of a run: Section 5's start, and the checks of a given one.

Section 5 starts the deck at X = Y = Z = 0.3 mm and the balls at phi = +-60 deg; for more
balls :func:`default_phi0` spreads them in two groups. :func:`initial_state` packs a start
into the state vector (:mod:`abb_ros.model.dynamics.state`).
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics.state import StateLayout, wrap_angle
from abb_ros.model.parameters.params import DriveParams, ParamError

__all__ = ['INITIAL_DECK', 'INITIAL_PHI_DEG', 'CONTACT_START_GAP_DEG', 'default_phi0',
           'initial_state']

INITIAL_DECK = (0.3e-3, 0.3e-3, 0.3e-3, 0.0, 0.0, 0.0)
"""Section 5 initial conditions: X = Y = Z = 0.3 mm, alpha = beta = gamma = 0."""

INITIAL_PHI_DEG = 60.0
"""Section 5: phi_1(0) = -phi_2(0) = 60 deg."""
CONTACT_START_GAP_DEG = 0.1
"""With contact, neighbouring balls of a default start are this far beyond touching [deg]."""


def default_phi0(n: int, separation: float = 0.0) -> np.ndarray:
    """Return the initial ball angles [rad].

    Section 5's +-60 deg; for n > 2 the balls alternate
    between the two groups, each group spread by 1 deg steps (identical balls started at the
    same angle would move as one), or, with contact, by the balls' contact
    ``separation`` [rad] plus 0.1 deg when that is wider: the balls then start side by side,
    just apart.
    """
    step = 1.0
    if math.degrees(separation) + CONTACT_START_GAP_DEG > step:
        step = math.degrees(separation) + CONTACT_START_GAP_DEG
    phi = np.empty(n)
    for i in range(n):
        group, rank = i % 2, i // 2
        sign = 1.0 if group == 0 else -1.0
        phi[i] = sign * (INITIAL_PHI_DEG + rank * step)
    return np.radians(phi)


def initial_state(params: DriveParams, omega: float, phi0=None, deck0=INITIAL_DECK,
                  theta0: float = 0.0) -> np.ndarray:
    """Return the state y0 of Section 5 at spindle speed omega [rad/s]; shape (2N,)."""
    n = params.n_balls
    if phi0 is None:
        # each race starts from its own fan of Section 5 (race 2's balls after race 1's)
        phi = np.concatenate([
            default_phi0(params.n, params.contact_separation if params.contact_E > 0 else 0.0),
            default_phi0(params.race2_n, 0.0)])
    else:
        phi = np.asarray(phi0, dtype=float)
    if phi.shape != (n,):
        counts = f'n = {n}' if not params.race2_n else \
            f'n + race2.n = {params.n} + {params.race2_n}'
        raise ParamError('phi0', list(np.degrees(phi)), f'{n} ball angles ({counts})')
    _check_no_overlap(params, phi)
    return StateLayout(n).pack(theta=theta0, deck=deck0, phi=phi, omega=omega)


def _check_no_overlap(params: DriveParams, phi) -> None:
    """With contact balls may not start closer than 2 asin(r_ball / R)."""
    if params.contact_E <= 0 or params.n < 2:
        return
    d = np.subtract.outer(phi, phi)
    d = np.abs(wrap_angle(d))
    d[np.diag_indices(params.n)] = math.inf
    if d.min() < params.contact_separation * (1 - 1e-12):
        raise ParamError('phi0', f'{math.degrees(d.min()):.4f} deg between the closest balls',
                         f'at least 2 asin(r_ball / R) = '
                         f'{math.degrees(params.contact_separation):.4f} deg',
                         'with contact the balls cannot overlap')

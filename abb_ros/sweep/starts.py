"""Initial conditions as drawn parameters of a sweep: ball angles and the deck's displacement.

A sweep spec may vary, besides the drive, where each run starts (docs/sweep.md), so that a lot
of drives is studied with random starts and the report gives the probability of balancing:

- ``phi1_deg``, ``phi2_deg``, ... ``phi<K>_deg``: the initial angle of ball i [deg], within
  [-360, 360]; drawn together they must be phi1..phiK with K at least every drive's ball
  count (ball i > K is never given a start, so none is left to a default);
- ``X0``, ``Y0``, ``Z0``: the deck's initial translation [m], within the model's envelope
  (|X| <= MAX_TRANSLATION); the others keep the scenario's start.

They need ``compute.run`` (the stability analysis starts from no initial state), and they do
not change the drive: :func:`split` takes them out before the drive's settings are applied.
"""

from __future__ import annotations

import re

import numpy as np

from abb_ros.model.dynamics.kernels.layout import MAX_TRANSLATION
from abb_ros.model.parameters.params import ParamError

__all__ = ['MAX_BALLS', 'START_PARAMETERS', 'DECK_STARTS', 'is_start', 'check_start_value',
           'check_starts', 'split', 'initial_states']

MAX_BALLS = 32
"""Most ball angles a spec may draw (phi1_deg .. phi32_deg)."""

DECK_STARTS = ('X0', 'Y0', 'Z0')
"""The deck's initial translation [m], as drawn parameters."""

START_PARAMETERS = tuple(f'phi{i}_deg' for i in range(1, MAX_BALLS + 1)) + DECK_STARTS
"""Every start parameter a sweep spec may draw."""

_PHI = re.compile(r'^phi(\d+)_deg$')


def is_start(name: str) -> bool:
    """Return whether ``name`` is a start parameter (not a drive parameter)."""
    return name in START_PARAMETERS


def check_start_value(where: str, name: str, value) -> None:
    """Refuse a value of a start parameter outside its range (ParamError naming ``where``)."""
    bound, unit = (360.0, 'deg') if _PHI.match(name) else (MAX_TRANSLATION, 'm')
    if not -bound <= value <= bound:
        raise ParamError(where, value, f'[{-bound:g}, {bound:g}] {unit}',
                         f'outside the valid range of {name}')


def check_starts(parameters: dict, ball_counts, run) -> None:
    """Check the drawn start parameters together: phi1..phiK for every ball count, with runs."""
    starts = [k for k in parameters if is_start(k)]
    if not starts:
        return
    if run is None:
        raise ParamError(f'parameters.{starts[0]}', parameters[starts[0]],
                         'drawn only with compute.run (a start of the nonlinear run)')
    balls = sorted(int(_PHI.match(k).group(1)) for k in starts if _PHI.match(k))
    if balls and balls != list(range(1, len(balls) + 1)):
        raise ParamError('parameters', [f'phi{i}_deg' for i in balls],
                         'ball angles phi1_deg .. phiK_deg, none left out')
    most = max(ball_counts)
    if balls and len(balls) < most:
        raise ParamError(f'parameters.phi{len(balls) + 1}_deg', None,
                         f'drawn: the sweep has drives of {most} balls', 'missing')


def split(settings: dict) -> tuple[dict, dict]:
    """Return (drive settings, start values) of one sample's drawn values."""
    drive = {k: v for k, v in settings.items() if not is_start(k)}
    return drive, {k: v for k, v in settings.items() if is_start(k)}


def initial_states(scenario, columns: dict, idx, n: int):
    """Return (phi0 [rad] shape (len(idx), n) or None, deck0 per sample) for samples ``idx``.

    Ball angles from phi1_deg..phin_deg when drawn (else the scenario's, None: the default
    start), the deck's translation from X0, Y0, Z0 where drawn, the rest of the scenario's deck
    start kept.
    """
    idx = np.asarray(idx)
    if 'phi1_deg' in columns:
        phi0 = np.radians(np.stack([np.asarray(columns[f'phi{i + 1}_deg'], float)[idx]
                                    for i in range(n)], axis=1))
    elif scenario.phi0 is not None and len(scenario.phi0) == n:
        phi0 = np.tile(np.asarray(scenario.phi0, float), (idx.size, 1))
    else:
        phi0 = None
    deck0 = np.tile(np.asarray(scenario.deck0, float), (idx.size, 1))
    for j, name in enumerate(DECK_STARTS):
        if name in columns:
            deck0[:, j] = np.asarray(columns[name], float)[idx]
    return phi0, deck0

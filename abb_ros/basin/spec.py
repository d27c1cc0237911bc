"""What a basin study computes: the scenario, the starts and the limits of a balanced end.

A :class:`BasinSpec` holds the scenario (drive, speed profile, deck start, with any ``--set``
applied), the run options of ``abb-sim run`` (step, publish period), the starts and the
criteria of :mod:`abb_ros.model.stability.outcomes`. The starts are the initial ball angles [deg]:

- ``grid`` (n = 2): res[0] x res[1] cell centres over [-180, 180) x [-180, 180), phi1 the
  slow index: ``phi = -180 + (k + 1/2) 360 / N``;
- ``samples`` (any n >= 2): K starts with every angle drawn uniformly on [-180, 180) by
  numpy's default generator (PCG64) seeded with ``seed``: ``default_rng(seed).uniform(-180,
  180, (K, n))``.

All starts are made up front, then cut into partitions of ``partition_size`` (start i is in
partition i // partition_size), so a start's result does not depend on the partitioning or
on where it runs. ``doc`` is the normalised spec (JSON-able) that a resumed study must match.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from abb_ros.model.parameters.params import ParamError

__all__ = ['BasinSpec', 'MAX_STARTS', 'MAX_PARTITION', 'parse_res', 'start_columns']

MAX_STARTS = 16384
"""Most starts of one study (a 128 x 128 grid): each is a full nonlinear run."""

MAX_PARTITION = 4096
"""Largest partition (starts per task and per Parquet file)."""


def parse_res(text: str) -> tuple[int, int]:
    """Return (N, M) of ``--res NxM``; ParamError names ``--res`` and what is valid."""
    valid = f'NxM with N, M >= 2 and N M <= {MAX_STARTS}'
    parts = str(text).lower().split('x')
    try:
        res = tuple(int(p) for p in parts)
    except ValueError:
        raise ParamError('--res', text, valid) from None
    if len(res) != 2 or min(res) < 2 or res[0] * res[1] > MAX_STARTS:
        raise ParamError('--res', text, valid)
    return res


def start_columns(n: int) -> list[str]:
    """Return the names of the start columns, phi1_deg .. phin_deg."""
    return [f'phi{i + 1}_deg' for i in range(n)]


@dataclass
class BasinSpec:
    """A basin study (module docstring). ``res`` for a grid, else ``samples`` and ``seed``."""

    scenario: object             # io.scenario.Scenario, settings applied
    options: dict                # run_scenario's dt, publish_dt, integrator
    settings: dict               # the --set values (for doc)
    rbar_limit: float
    rest_tol_deg: float
    res: tuple | None = None
    samples: int | None = None
    seed: int = 0
    partition_size: int = 64

    def __post_init__(self):
        n = self.scenario.params.n_balls
        if n < 2:
            raise ParamError('n', n, 'at least 2 balls for a basin study')
        if (self.res is None) == (self.samples is None):
            raise ParamError('--res/--samples', None, 'exactly one of them')
        if self.res is not None and n != 2:
            raise ParamError('--res', f'{self.res[0]}x{self.res[1]}',
                             f'only with n = 2 balls (n = {n}: use --samples K)')
        if self.samples is not None and not 1 <= self.samples <= MAX_STARTS:
            raise ParamError('--samples', self.samples, f'1..{MAX_STARTS}')
        if not 0 <= self.seed < 2 ** 63:
            raise ParamError('--seed', self.seed, f'0..{2 ** 63 - 1}')
        if not 1 <= self.partition_size <= MAX_PARTITION:
            raise ParamError('--partition-size', self.partition_size, f'1..{MAX_PARTITION}')
        for name, value in (('--rbar-limit', self.rbar_limit),
                            ('--rest-tol', self.rest_tol_deg)):
            if not (math.isfinite(value) and value > 0):
                raise ParamError(name, value, '(0, inf)')

    @property
    def n(self) -> int:
        """Ball count (both races: race 1's then race 2's, as in the state)."""
        return self.scenario.params.n_balls

    @property
    def total(self) -> int:
        """Number of starts."""
        return self.res[0] * self.res[1] if self.res is not None else self.samples

    @property
    def partitions(self) -> int:
        """Number of partitions."""
        return -(-self.total // self.partition_size)

    def partition_bounds(self, index: int) -> tuple[int, int]:
        """Return [start, stop) of partition ``index``."""
        start = index * self.partition_size
        return start, min(start + self.partition_size, self.total)

    @property
    def sampler(self) -> str:
        """How the starts were made, in words (reported with the results)."""
        if self.res is not None:
            return f'grid {self.res[0]}x{self.res[1]} of cell centres over [-180, 180) deg'
        return (f'uniform on [-180, 180) deg per ball, numpy default_rng({self.seed}) '
                '(PCG64)')

    @property
    def doc(self) -> dict:
        """The normalised spec (JSON-able): what a resumed study must match."""
        scen = self.scenario
        return {'kind': 'basin', 'scenario': scen.name, 'settings': self.settings,
                'n': self.n, 'duration': scen.duration, 'omega0_rad_s': scen.omega,
                'deck0': [float(v) for v in scen.deck0],
                'options': {k: float(v) for k, v in sorted(self.options.items())
                            if k in ('dt', 'publish_dt')},
                'integrator': self.integrator,
                'res': list(self.res) if self.res else None, 'samples': self.samples,
                'seed': self.seed, 'sampler': self.sampler, 'rbar_limit': self.rbar_limit,
                'rest_tol_deg': self.rest_tol_deg, 'partition_size': self.partition_size}

    @property
    def integrator(self) -> str:
        """The integrator of every start, as ``abb-sim run --integrator`` names it."""
        return self.options.get('integrator', 'rk4')

    def draw(self) -> dict:
        """Return every start: {'phi1_deg': array, ...} in start order (module docstring)."""
        if self.res is not None:
            N, M = self.res
            a = -180.0 + (np.arange(N) + 0.5) * 360.0 / N
            b = -180.0 + (np.arange(M) + 0.5) * 360.0 / M
            A, B = np.meshgrid(a, b, indexing='ij')
            phi = np.stack([A.ravel(), B.ravel()], axis=1)
        else:
            phi = np.random.default_rng(self.seed).uniform(-180.0, 180.0,
                                                           (self.samples, self.n))
        return {name: phi[:, i].copy() for i, name in enumerate(start_columns(self.n))}

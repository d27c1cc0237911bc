"""The drives of a sweep, drawn up front from its spec's seed.

:func:`draw_samples` gives every sample of a :class:`~abb_ros.sweep.spec.SweepSpec` before the
samples are cut into partitions, so the samples and the results do not depend on how the work
is partitioned or where it runs: unit draws (pseudo-random, Latin hypercube or scrambled
Sobol) transformed by each parameter's distribution, repeated over the grid points.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np

from abb_ros.sweep.spec import SweepSpec

__all__ = ['draw_samples']


def _unit_draws(method, seed, count, dims):
    """(count, dims) points in [0, 1): pseudo-random, Latin hypercube or scrambled Sobol."""
    if dims == 0:
        return np.zeros((count, 0))
    if method == 'random':
        return np.random.default_rng(seed).random((count, dims))
    from scipy.stats import qmc
    if method == 'lhs':
        return qmc.LatinHypercube(d=dims, rng=np.random.default_rng(seed)).random(count)
    with warnings.catch_warnings():   # balance properties want 2^m points; any count is valid
        warnings.simplefilter('ignore', UserWarning)
        return qmc.Sobol(d=dims, scramble=True, rng=np.random.default_rng(seed)).random(count)


def _transform(dist, u):
    kind = dist['dist']
    if kind == 'uniform':
        return dist['low'] + (dist['high'] - dist['low']) * u
    if kind == 'normal':
        from scipy.stats import truncnorm
        a = (dist['low'] - dist['mean']) / dist['std']
        b = (dist['high'] - dist['mean']) / dist['std']
        x = truncnorm.ppf(u, a, b, loc=dist['mean'], scale=dist['std'])
        return np.clip(x, dist['low'], dist['high'])
    values = np.asarray(dist['values'])
    return values[np.minimum((u * len(values)).astype(np.int64), len(values) - 1)]


def draw_samples(spec: SweepSpec) -> dict:
    """Every sample of the sweep, drawn up front from the seed: {parameter: array (total,)}.

    Sample i = g * samples + j is grid point g (grid parameters in spec order, the last
    fastest) with draw j.
    """
    drawn = spec.drawn
    u = _unit_draws(spec.method, spec.seed, spec.samples, len(drawn))
    draws = {name: _transform(spec.parameters[name], u[:, i]) for i, name in enumerate(drawn)}
    grid = spec.grid
    combos = list(itertools.product(*grid.values())) if grid else [()]
    out = {}
    for name in spec.parameters:
        if name in grid:
            col = np.repeat(np.asarray([c[list(grid).index(name)] for c in combos]), spec.samples)
        else:
            col = np.tile(draws[name], len(combos))
        out[name] = col.astype(np.int64) if name == 'n' else col.astype(float)
    return out

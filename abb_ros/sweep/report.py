"""Pictures and a JSON summary of a finished (or partly finished) sweep directory.

``abb-sim sweep-report DIR --out fig/`` reads the Parquet dataset of ``abb-sim sweep`` and
writes:

- ``hist_final_rbar.png``, ``hist_settle_time.png`` (with ``compute.run``);
- ``hist_lambda_op.png``: |lambda|max at the operating speed (with ``compute.stability``);
- ``balanced_vs_<parameter>.png``: the fraction of drives balanced against each varied
  parameter (quantile bins, or the distinct values of a list or grid), with the 95 % Wilson
  interval of ``balanced`` per bin (also in the summary, ``balanced_by_bin``);
- ``scatter_<p1>_<p2>.png``: the drives over the two most influential parameters, balanced
  and unbalanced apart;
- ``summary.json``: the yield (fraction balanced at the operating speed: both |lambda|max < 1
  with ``stability``, else final rbar <= rbar_limit), over the speed range, failed runs by
  cause, each parameter's influence and the worst drives with their parameters.

Influence of a parameter is |Spearman's rho| between it and the drive's margin: 1 - max(|lambda|
in, out) at the operating speed with ``stability`` (-1 where no balanced equilibrium exists),
else -log10(final rbar); with several stability speeds also against the margin over all of
them (1 - the largest |lambda|max), and then the scatter shows that ranking and the drives
balanced at every speed. It ranks monotonic effects only; the pictures show the rest.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from abb_ros.plots import sweep_report as figs
from abb_ros.sweep.store import read_results

__all__ = ['make_report', 'WORST']

WORST = 10
"""Worst drives listed in the summary."""


def _col(table, name):
    return table.column(name).to_numpy(zero_copy_only=False)


def _margin(table):
    names = table.column_names
    if 'lam_in_op' in names:
        lam = np.maximum(_col(table, 'lam_in_op'), _col(table, 'lam_out_op'))
        return (np.where(np.isfinite(lam), 1.0 - lam, -1.0),
                '1 - |lambda|max at the operating speed')
    rbar = np.maximum(_col(table, 'final_rbar'), 1e-300)
    return -np.log10(rbar), '-log10(final rbar)'


def _influence(table, parameters, margin):
    from scipy.stats import spearmanr
    out = {}
    for name in parameters:
        x = _col(table, name).astype(float)
        if np.ptp(x) == 0 or np.ptp(margin) == 0:
            out[name] = 0.0
            continue
        rho = spearmanr(x, margin).statistic
        out[name] = 0.0 if not math.isfinite(rho) else abs(float(rho))
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def _bins(x, discrete):
    """Return each x's bin index and the bin centres: distinct values or up to 12 quantile bins."""
    values = np.unique(x)
    if discrete or values.size <= 12:
        return np.searchsorted(values, x), values
    edges = np.unique(np.quantile(x, np.linspace(0, 1, 13)))
    idx = np.clip(np.searchsorted(edges, x, side='right') - 1, 0, edges.size - 2)
    centres = np.array([x[idx == i].mean() if np.any(idx == i) else np.nan
                        for i in range(edges.size - 1)])
    return idx, centres


def _unit(name):
    from abb_ros.model.parameters.params import PARAM_SPECS
    spec = PARAM_SPECS.get(name)
    return f'{name} [{spec.unit}]' if spec and spec.unit else name


def _planned_samples(spec: dict) -> int:
    """Return the drives the spec asks for: its samples times the points of each grid."""
    total = spec.get('samples', 0)
    for dist in spec.get('parameters', {}).values():
        if dist.get('dist') == 'grid':
            total *= len(dist['values'])
    return total


def make_report(sweep_dir, out_dir) -> dict:
    """Write the figures and summary.json into out_dir; returns the summary."""
    table, info = read_results(sweep_dir)
    spec = info['spec']
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    parameters = list(spec.get('parameters', {}))
    names = table.column_names
    count = table.num_rows
    balanced = _col(table, 'balanced').astype(bool)
    margin, margin_text = _margin(table)
    influence = _influence(table, parameters, margin)
    figures = []
    summary = {'name': spec.get('name'), 'version': info['version'], 'samples': count,
               'samples_planned': None, 'yield': float(balanced.mean()),
               'yield_definition': ('both |lambda|max < 1 at the operating speed'
                                    if 'balanced_op' in names else
                                    'final rbar <= compute.run.rbar_limit'),
               'margin': margin_text, 'influence_abs_spearman': influence}
    summary['samples_planned'] = _planned_samples(spec)
    scatter_by = (influence, balanced, 'at the operating speed')
    if 'balanced_all_speeds' in names:
        summary['yield_all_speeds'] = float(_col(table, 'balanced_all_speeds').mean())
        worst = np.maximum(_col(table, 'lam_in_max'), _col(table, 'lam_out_max'))
        over_range = _influence(table, parameters,
                                np.where(np.isfinite(worst), 1.0 - worst, -1.0))
        summary['influence_all_speeds_abs_spearman'] = over_range
        if len(spec['compute']['stability']) and 'omega_worst' in names \
                and np.unique(_col(table, 'omega_worst')).size > 1:
            scatter_by = (over_range, _col(table, 'balanced_all_speeds').astype(bool),
                          'at every speed of the spec (red: not)')
        summary['no_balanced_equilibrium'] = int((~_col(table, 'balanced_equilibrium_exists')
                                                  .astype(bool)).sum())
        lam = np.maximum(_col(table, 'lam_in_op'), _col(table, 'lam_out_op'))
        fin = lam[np.isfinite(lam)]
        figures.append(figs.lambda_histogram(out / 'hist_lambda_op.png', fin, count))
    if 'final_rbar' in names:
        rbar = _col(table, 'final_rbar')
        failed = _col(table, 'failed').astype(bool)
        settle = _col(table, 'settle_time')
        limit = spec['compute']['run'].get('rbar_limit')
        summary['run_balanced_fraction'] = float(_col(table, 'run_balanced').mean())
        statuses, counts = np.unique(_col(table, 'status'), return_counts=True)
        summary['run_status_counts'] = {str(s): int(c) for s, c in zip(statuses, counts)}
        good = rbar[~failed]
        summary['final_rbar_quantiles'] = _quantiles(good)
        summary['settle_time_s_quantiles'] = _quantiles(settle[np.isfinite(settle)])
        summary['never_settled'] = int((~np.isfinite(settle)).sum())
        figures.append(figs.final_rbar_histogram(out / 'hist_final_rbar.png', good, limit))
        figures.append(figs.settle_time_histogram(out / 'hist_settle_time.png',
                                                  settle[np.isfinite(settle)],
                                                  summary['never_settled']))
    for name in parameters:
        x = _col(table, name).astype(float)
        discrete = spec['parameters'][name].get('dist') in ('list', 'grid')
        idx, centres = _bins(x, discrete)
        frac = {key: np.array([_col(table, key)[idx == i].mean() if np.any(idx == i) else np.nan
                               for i in range(centres.size)])
                for key in ('balanced_op', 'balanced_all_speeds', 'run_balanced') if key in names}
        bins = _bin_intervals(table, idx, centres)
        summary.setdefault('balanced_by_bin', {})[name] = bins
        ci95 = [np.array([b['ci95'][k] for b in bins], dtype=float) for k in (0, 1)]
        figures.append(figs.balanced_fraction(out / f'balanced_vs_{name}.png', centres, frac,
                                              ci95, _unit(name)))
    ranking, ok, where = scatter_by
    top = list(ranking)[:2]
    if len(top) == 2:
        xa, ya = _col(table, top[0]).astype(float), _col(table, top[1]).astype(float)
        figures.append(figs.two_parameter_scatter(
            out / f'scatter_{top[0]}_{top[1]}.png', xa, ya, ok,
            (_unit(top[0]), _unit(top[1])), where))
    order = np.argsort(margin, kind='stable')[:WORST]
    show = ['sample'] + parameters + [c for c in (
        'omega0', 'zeta', 'lam_in_op', 'lam_out_op', 'omega_worst', 'final_rbar', 'peak_rbar',
        'settle_time', 'status', 'cause') if c in names and c not in parameters]
    summary['worst'] = [{c: _jsonable(_col(table, c)[i]) for c in show} for i in order]
    summary['figures'] = [Path(f).name for f in figures]
    with open(out / 'summary.json', 'w', encoding='utf-8') as f:
        json.dump(summary, f, indent=1)
        f.write('\n')
    return summary


def _bin_intervals(table, idx, centres) -> list:
    """Return per bin: centre, runs, balanced count, fraction and its 95 % Wilson interval.

    Runs whose drawn ball angles overlap (status 'overlap') are left out: they never ran.
    """
    from abb_ros.sweep.proportions import wilson
    balanced = _col(table, 'balanced').astype(bool)
    ran = np.ones(balanced.size, dtype=bool)
    if 'status' in table.column_names:
        ran = _col(table, 'status') != 'overlap'
    out = []
    for i, centre in enumerate(centres):
        sel = (idx == i) & ran
        k, n = int(balanced[sel].sum()), int(sel.sum())
        out.append({'centre': _jsonable(centre), 'runs': n, 'balanced': k,
                    'fraction': k / n if n else None,
                    'ci95': list(wilson(k, n)) if n else [None, None]})
    return out


def _quantiles(x):
    if x.size == 0:
        return {}
    q = np.quantile(x, [0.5, 0.95, 0.99])
    return {'p50': float(q[0]), 'p95': float(q[1]), 'p99': float(q[2]), 'max': float(x.max())}


def _jsonable(v):
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    return v

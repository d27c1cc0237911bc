"""The picture of a basin study (PNG, :mod:`abb_ros.plots.figure`).

- n = 2 on a grid: the start plane (phi1, phi2) [deg] coloured by outcome class, the
  balanced equilibria of Eq. (26) marked (the symmetric pair and its mirror, the balls
  exchanged), and the final angles of the balanced runs as dots;
- n = 2 sampled: the same plane with the starts as dots;
- n >= 3: the class counts as bars, with the balanced fraction and its interval.

The title carries the scenario, the balanced fraction with its 95 % Wilson interval, and the
Floquet verdict at the operating speed.
"""

from __future__ import annotations

import numpy as np

from abb_ros.plots.figure import pyplot, save
from abb_ros.plots.labels import fit_title

__all__ = ['COLOURS', 'basin_picture']

COLOURS = {'balanced': '#2ca02c', 'settling': '#98df8a', 'packed': '#d62728',
           'friction_rest': '#ff7f0e', 'unbalanced_rest': '#9467bd', 'moving': '#1f77b4',
           'drifting': '#17becf', 'failed': '#000000', 'overlap': '#bbbbbb'}
"""Colour of each outcome class."""


def _title(spec, summary) -> str:
    frac = summary['balanced_fraction']
    head = f'{spec.scenario.name}, n = {spec.n}, {summary["runs"]} runs of ' \
           f'{spec.scenario.duration:g} s'
    if frac is None:
        return head
    lo, hi = summary['ci95']
    fl = summary['floquet']
    verdict = fl.get('verdict', 'no verdict')
    lam = ''
    if fl.get('lam_in') is not None:
        lam = f' (|lambda|max in {fl["lam_in"]:.4f}, out {fl["lam_out"]:.4f})'
    return (f'{head}\nP(balance) = {frac:.3f} [{lo:.3f}, {hi:.3f}] 95 %; '
            f'Floquet at wbar {fl.get("wbar", float("nan")):.3g}: {verdict}{lam}')


def basin_picture(spec, table, summary, path) -> None:
    """Write the study's picture (module docstring) to ``path`` (PNG)."""
    from matplotlib.patches import Patch
    plt = pyplot()

    outcome = np.asarray(table.column('outcome').to_pylist(), dtype=object)
    present = [c for c in COLOURS if np.any(outcome == c)]
    if spec.n == 2:
        fig, ax = plt.subplots(figsize=(6.4, 6.2))
        p1 = table.column('phi1_deg').to_numpy()
        p2 = table.column('phi2_deg').to_numpy()
        if spec.res is not None:
            N, M = spec.res
            codes = np.array([list(COLOURS).index(c) for c in outcome]).reshape(N, M)
            from matplotlib.colors import ListedColormap
            cmap = ListedColormap(list(COLOURS.values()))
            edges1 = np.linspace(-180, 180, N + 1)
            edges2 = np.linspace(-180, 180, M + 1)
            ax.pcolormesh(edges1, edges2, codes.T, cmap=cmap, vmin=-0.5,
                          vmax=len(COLOURS) - 0.5, shading='flat')
        else:
            ax.scatter(p1, p2, c=[COLOURS[c] for c in outcome], s=8)
        bal = outcome == 'balanced'
        if np.any(bal):
            ax.plot(table.column('phi1_final_deg').to_numpy()[bal],
                    table.column('phi2_final_deg').to_numpy()[bal], '.', color='white',
                    ms=2, label='final angles (balanced runs)')
        star = summary['floquet'].get('phi_star_deg') or []
        if len(star) == 2:
            ax.plot([star[0], star[1]], [star[1], star[0]], 'k*', ms=14, mfc='yellow',
                    label='Eq. (26) equilibria')
        ax.set_xlim(-180, 180)
        ax.set_ylim(-180, 180)
        ax.set_xticks(range(-180, 181, 60))
        ax.set_yticks(range(-180, 181, 60))
        ax.set_xlabel('phi1(0) [deg]')
        ax.set_ylabel('phi2(0) [deg]')
        ax.set_aspect('equal')
        handles = [Patch(color=COLOURS[c], label=c) for c in present]
        handles += ax.get_legend_handles_labels()[0]
        ax.legend(handles=handles, loc='upper left', fontsize=7, framealpha=0.85)
    else:
        fig, ax = plt.subplots(figsize=(7.0, 4.2))
        counts = summary['outcomes']
        names = [c for c in COLOURS if counts.get(c, 0) > 0]
        ax.bar(names, [counts[c] for c in names], color=[COLOURS[c] for c in names])
        ax.set_ylabel('starts')
        ax.set_xlabel('outcome')
    fit_title(fig, ax, _title(spec, summary), fontsize=8)
    save(fig, path, file_format='png')

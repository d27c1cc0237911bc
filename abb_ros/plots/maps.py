"""PNG figures of stability maps (Figs. 4-8 of the paper). matplotlib is imported lazily.

The balanced (stable) region is shaded with dots as in the paper; the unbalanced region,
including points with no balanced equilibrium, is left unmarked; the limit lines of Figs. 6
and 7 (epsbar_lim, mbar_lim) are drawn solid. ``kind='surface'`` draws |lambda|max as a 3-D
surface (Fig. 4a).
"""

from __future__ import annotations

from abb_ros.plots.figure import pyplot, save
from abb_ros.plots.labels import SYMBOLS as LABELS
from abb_ros.plots.labels import fit_title, parameter_text

LIMIT_LABELS = {'mbar_lim': r'$\bar{m}_{lim}$', 'epsbar_lim': r'$\bar{\varepsilon}_{lim}$'}
REGION_NAMES = {'in': ('balanced and stable', 'unbalanced or no balanced equilibrium'),
                'out': ('out-of-plane stable',
                        'out-of-plane unstable or no balanced equilibrium'),
                'coupled': ('balanced and stable (coupled)',
                            'unbalanced or no balanced equilibrium')}
"""Legend entries (dotted, blank) per plane: an out-of-plane map says nothing of balancing."""
SURFACE_CLIP = 2.0
"""|lambda|max above this is drawn at this height on the surface plot (unbalanced anyway)."""


def plot_map(smap, path, title=None, kind='regions') -> None:
    """Write the map ``smap`` (floquet.StabilityMap) as a PNG at ``path``."""
    import numpy as np

    from abb_ros.model.stability.floquet import BALANCED
    plt = pyplot()
    X, Y = np.meshgrid(smap.x_values, smap.y_values)
    if kind == 'surface':
        fig = plt.figure(figsize=(6.4, 5.0))
        ax = fig.add_subplot(projection='3d')
        Z = np.minimum(smap.lam, SURFACE_CLIP)
        ax.plot_surface(X, Y, Z, cmap='viridis', linewidth=0, antialiased=True)
        ax.set_zlabel(r'$|\lambda|_{max}$')
    else:
        fig, ax = plt.subplots(figsize=(6.0, 5.4))
        balanced = (smap.status == BALANCED).astype(float)
        ax.contourf(X, Y, balanced, levels=[0.5, 1.5], colors='none', hatches=['..'])
        ax.contour(X, Y, balanced, levels=[0.5], colors='k', linewidths=0.8)
        limits = []
        for name, value in smap.limits.items():
            if smap.y == name.replace('_lim', ''):
                limits.append(ax.axhline(value, color='k', linewidth=1.5,
                                         label=_limit_text(name, value)))
            elif smap.x == name.replace('_lim', ''):
                limits.append(ax.axvline(value, color='k', linewidth=1.5,
                                         label=_limit_text(name, value)))
        ax.set_xlim(smap.x_values[0], smap.x_values[-1])
        ax.set_ylim(smap.y_values[0], smap.y_values[-1])
        _region_legend(ax, smap.plane, limits)
    ax.set_xlabel(LABELS[smap.x])
    ax.set_ylabel(LABELS[smap.y])
    fit_title(fig, ax, title or map_title(smap))
    save(fig, path)


def _limit_text(name, value) -> str:
    side = 'below' if name == 'mbar_lim' else 'above'
    return f'{LIMIT_LABELS[name]} = {value:.2g}: no balanced equilibrium {side}'


def _region_legend(ax, plane, limits) -> None:
    """Draw the dotted / blank / limit-line legend below the axes, where it covers no data."""
    from matplotlib.patches import Patch
    dotted, blank = REGION_NAMES[plane]
    ax.legend(handles=[Patch(facecolor='white', edgecolor='k', hatch='..', label=dotted),
                       Patch(facecolor='white', edgecolor='k', label=blank), *limits],
              loc='upper center', bbox_to_anchor=(0.5, -0.12), ncol=1, fontsize=8,
              frameon=False)


def map_title(smap) -> str:
    """Return the map's title: its plane and the parameters held fixed (others: Table 1 values)."""
    from abb_ros.model.parameters.params import DriveParams
    params = DriveParams(**smap.fixed['SI'])
    wbar = smap.fixed['settings'].get('wbar')
    plane = {'in': 'In-plane', 'out': 'Out-of-plane', 'coupled': 'Coupled'}[smap.plane]
    return f'{plane} stability: ' + parameter_text(params, wbar, omit=(smap.x, smap.y))


def plot_speed_curves(curves, path, title=None) -> None:
    """Plot |lambda|max against wbar for several drives side by side, one panel each.

    ``curves`` : list of (label, wbar (K,), lam_in (K,), lam_out (K,)); the line
    |lambda| = 1 separates balanced from unbalanced speeds.
    """
    import numpy as np
    plt = pyplot()
    fig, axes = plt.subplots(1, len(curves), figsize=(5.2 * len(curves), 4.0), sharey=True,
                             squeeze=False)
    for ax, (label, wbar, lam_in, lam_out) in zip(axes[0], curves):
        ax.plot(wbar, np.minimum(lam_in, SURFACE_CLIP), label='in-plane (transverse)')
        ax.plot(wbar, np.minimum(lam_out, SURFACE_CLIP), '--', label='out-of-plane')
        ax.axhline(1.0, color='k', lw=0.8)
        ax.set_title(label)
        ax.set_xlabel(LABELS['wbar'])
        ax.set_ylim(0.8, 1.25)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel(r'$|\lambda|_{max}$')
    axes[0][0].legend(loc='upper right')
    if title:
        fig.suptitle(title)
    save(fig, path, dpi=100)

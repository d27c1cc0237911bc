"""PNG figures of stability maps (Figs. 4-8 of the paper). matplotlib is imported lazily.

The balanced (stable) region is shaded with dots as in the paper; the unbalanced region,
including points with no balanced equilibrium, is left unmarked; the limit lines of Figs. 6
and 7 (epsbar_lim, mbar_lim) are drawn solid. ``kind='surface'`` draws |lambda|max as a 3-D
surface (Fig. 4a).
"""

from __future__ import annotations

LABELS = {'wbar': r'$\bar{\omega}$', 'zeta': r'$\zeta$', 'Dbar': r'$\bar{D}$',
          'epsbar': r'$\bar{\varepsilon}$', 'mbar': r'$\bar{m}$'}
LIMIT_LABELS = {'mbar_lim': r'$\bar{m}_{lim}$', 'epsbar_lim': r'$\bar{\varepsilon}_{lim}$'}
SURFACE_CLIP = 2.0
"""|lambda|max above this is drawn at this height on the surface plot (unbalanced anyway)."""


def _pyplot():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def plot_map(smap, path, title=None, kind='regions') -> None:
    """Write the map ``smap`` (floquet.StabilityMap) as a PNG at ``path``."""
    import numpy as np
    from abb_ros.model.floquet import BALANCED
    plt = _pyplot()
    X, Y = np.meshgrid(smap.x_values, smap.y_values)
    if kind == 'surface':
        fig = plt.figure(figsize=(6.4, 5.0))
        ax = fig.add_subplot(projection='3d')
        Z = np.minimum(smap.lam, SURFACE_CLIP)
        ax.plot_surface(X, Y, Z, cmap='viridis', linewidth=0, antialiased=True)
        ax.set_zlabel(r'$|\lambda|_{max}$')
    else:
        fig, ax = plt.subplots(figsize=(6.0, 4.6))
        balanced = (smap.status == BALANCED).astype(float)
        ax.contourf(X, Y, balanced, levels=[0.5, 1.5], colors='none', hatches=['..'])
        ax.contour(X, Y, balanced, levels=[0.5], colors='k', linewidths=0.8)
        for name, value in smap.limits.items():
            if smap.y == name.replace('_lim', ''):
                ax.axhline(value, color='k', linewidth=1.5)
                ax.annotate(LIMIT_LABELS[name], (smap.x_values[-1], value), xytext=(-30, 4),
                            textcoords='offset points')
            elif smap.x == name.replace('_lim', ''):
                ax.axvline(value, color='k', linewidth=1.5)
        ax.set_xlim(smap.x_values[0], smap.x_values[-1])
        ax.set_ylim(smap.y_values[0], smap.y_values[-1])
        ax.text(0.02, 0.97, 'dotted: balanced, stable   blank: unbalanced',
                transform=ax.transAxes, va='top', fontsize=8,
                bbox=dict(facecolor='white', edgecolor='none', alpha=0.8))
    ax.set_xlabel(LABELS[smap.x])
    ax.set_ylabel(LABELS[smap.y])
    plane = 'in-plane' if smap.plane == 'in' else 'out-of-plane'
    ax.set_title(title or f'Stability, {plane} ({_fixed_text(smap)})', fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _fixed_text(smap) -> str:
    """The settings held fixed over the map; the rest are Table 1 values."""
    parts = [f'{k}={v:.3g}' for k, v in smap.fixed['settings'].items()]
    return ', '.join(parts + ['others Table 1'])

"""Time-response figures of the paper (Figs. 9-16) from a recorded bag.

The ``plot_*`` functions draw a :class:`abb_ros.io.bag.time_response.TimeResponse` (a bag's deck
coordinates and ball angles, loaded by :func:`abb_ros.io.bag.time_response.load_time_response`).
matplotlib is imported only when drawing. SI inside; mm and degrees on the axes.
"""

from __future__ import annotations

import numpy as np

from abb_ros.io.bag.time_response import TimeResponse
from abb_ros.model.dynamics.state import wrap_degrees
from abb_ros.plots.figure import pyplot, save

LEGEND_OUTSIDE = dict(loc='upper left', bbox_to_anchor=(1.01, 1.0), fontsize=8, borderaxespad=0)
"""Legends right of the axes, where they cover no data."""
MAX_POINTS = 20000  # per curve; longer series are decimated for drawing


def _broken_at_wraps(deg: np.ndarray) -> np.ndarray:
    """Return a copy with NaN where wrapped angles jump by a turn (no vertical lines)."""
    deg = deg.copy()
    deg[..., 1:][np.abs(np.diff(deg, axis=-1)) > 180.0] = np.nan
    return deg


def _thin(t, *ys):
    step = max(1, len(t) // MAX_POINTS)
    return (t[::step],) + tuple(y[..., ::step] for y in ys)


def plot_rbar_and_balls(resp: TimeResponse, out, title: str = '') -> None:
    """Plot (a) rbar vs time, (b) ball angles phi_i (deg) vs time: Figs. 9-11, 15, 16."""
    plt = pyplot()
    fig, (ax_r, ax_phi) = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True)
    t, rbar = _thin(resp.t_pose, resp.rbar)
    ax_r.plot(t, rbar, lw=0.8, color='k')
    ax_r.set_ylabel(r'$\bar r = \sqrt{X^2+Y^2+Z^2}\,/\,R$')
    ax_r.set_title(f'(a) displacement of the centre (R = {resp.R * 1e3:g} mm)', fontsize=10)
    ax_r.grid(alpha=0.3)
    if resp.phi.size:
        t, phi = _thin(resp.t_joint, resp.phi)
        deg = _broken_at_wraps(wrap_degrees(phi))
        for i, row in enumerate(deg):
            ax_phi.plot(t, row, lw=0.8, label=rf'$\phi_{{{i + 1}}}$')
        if len(deg) <= 4:
            ax_phi.legend(**LEGEND_OUTSIDE)
    else:
        ax_phi.text(0.5, 0.5, 'no joint_states in the bag', ha='center',
                    transform=ax_phi.transAxes)
    ax_phi.set_ylim(-180, 180)
    ax_phi.set_yticks(range(-180, 181, 60))
    ax_phi.set_ylabel(r'ball angle $\phi_i$ (deg)')
    ax_phi.set_xlabel('time (s)')
    ax_phi.set_title('(b) angular positions of the balancing balls', fontsize=10)
    ax_phi.grid(alpha=0.3)
    _finish(fig, title, out)


DECK_PANELS = (('(a) X, in-plane', 'X (mm)', 1e3), ('(b) Y, in-plane', 'Y (mm)', 1e3),
               ('(c) Z, out-of-plane', 'Z (mm)', 1e3),
               (r'(d) $\alpha$, out-of-plane', r'$\alpha$ (deg)', np.degrees(1.0)),
               (r'(e) $\beta$, out-of-plane', r'$\beta$ (deg)', np.degrees(1.0)),
               (r'(f) $\gamma$, in-plane', r'$\gamma$ (deg)', np.degrees(1.0)))
"""Panels (a)-(f) of Figs. 12, 13: title, axis label, scale from SI."""


def plot_deck_coordinates(resp: TimeResponse, out, title: str = '') -> None:
    """Plot the six deck coordinates X, Y, Z (mm), alpha, beta, gamma (deg): Figs. 12, 13."""
    plt = pyplot()
    fig, axes = plt.subplots(3, 2, figsize=(10, 8), sharex=True)
    t, deck = _thin(resp.t_pose, resp.deck)
    order = (0, 3, 1, 4, 2, 5)  # column 1 translations, column 2 rotations
    for ax, k in zip(axes.flat, order):
        label, ylabel, scale = DECK_PANELS[k]
        ax.plot(t, deck[k] * scale, lw=0.7, color='k')
        ax.set_title(label, fontsize=10)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.ticklabel_format(axis='y', style='sci', scilimits=(-3, 3))
    for ax in axes[-1]:
        ax.set_xlabel('time (s)')
    _finish(fig, title, out)


def plot_abb_comparison(with_abb: TimeResponse, without_abb: TimeResponse, out,
                        title: str = '') -> None:
    """Plot rbar (a) with the ABB and (b) without it, on one scale: Fig. 14."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True, sharey=True)
    t_w, r_w = _thin(with_abb.t_pose, with_abb.rbar)
    t_n, r_n = _thin(without_abb.t_pose, without_abb.rbar)
    axes[0].plot(t_w, r_w, lw=0.8, color='k', label='with ABB')
    axes[1].plot(t_n, r_n, lw=0.8, color='tab:red', label='without ABB')
    axes[1].plot(t_w, r_w, lw=0.6, color='k', alpha=0.35, label='with ABB')
    axes[0].set_title('(a) ABB installed', fontsize=10)
    axes[1].set_title('(b) ABB not installed', fontsize=10)
    for ax in axes:
        ax.set_ylabel(r'$\bar r$')
        ax.grid(alpha=0.3)
        ax.legend(**LEGEND_OUTSIDE)
    axes[1].set_xlabel('time (s)')
    _finish(fig, title, out)


def _finish(fig, title, out) -> None:
    if title:
        fig.suptitle(title)
    save(fig, out)

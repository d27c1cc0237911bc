"""The figures of a sweep report (``abb-sim sweep-report``, :mod:`abb_ros.sweep.report`).

Each function draws one PNG from arrays the report has computed and returns its path.
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.plots.figure import axes_png

__all__ = ['balanced_fraction', 'final_rbar_histogram', 'lambda_histogram',
           'settle_time_histogram', 'two_parameter_scatter']

BINS = 60
"""Bars of every histogram."""


def lambda_histogram(path, lam, count: int) -> str:
    """Histogram |lambda|max at the operating speed of ``count`` drives (finite ``lam``)."""
    def draw(ax):
        ax.hist(lam, bins=BINS, color='tab:blue')
        ax.axvline(1.0, color='k', ls='--')
        ax.set_xlabel('|lambda|max at the operating speed (max of in-, out-of-plane)')
        ax.set_ylabel('drives')
        ax.set_title(f'{count} drives; > 1: unbalanced')
    return axes_png(path, draw)


def final_rbar_histogram(path, rbar, limit) -> str:
    """Histogram log10 of the final rbar of the runs that ran (``limit``: rbar_limit or None)."""
    logr = np.log10(np.maximum(rbar, 1e-300))

    def draw(ax):
        ax.hist(logr, bins=BINS, color='tab:green')
        if limit:
            ax.axvline(math.log10(limit), color='k', ls='--')
        ax.set_xlabel('log10 final rbar')
        ax.set_ylabel('drives')
        ax.set_title(f'final rbar of {rbar.size} runs (dashed: rbar_limit)')
    return axes_png(path, draw)


def settle_time_histogram(path, settle, never_settled: int) -> str:
    """Histogram the time to settle below rbar_limit [s] of the runs that did."""
    def draw(ax):
        ax.hist(settle, bins=BINS, color='tab:orange')
        ax.set_xlabel('settle time [s]')
        ax.set_ylabel('drives')
        ax.set_title(f'time to settle below rbar_limit ({never_settled} never did)')
    return axes_png(path, draw)


def balanced_fraction(path, centres, fractions: dict, ci95, xlabel: str) -> str:
    """Draw the fraction balanced per bin of one parameter, each definition a line.

    The 95 % Wilson interval of ``balanced`` (``ci95``: the (low, high) arrays) is shaded.
    """
    def draw(ax):
        for key, f in fractions.items():
            ax.plot(centres, f, 'o-', label=key)
        ax.fill_between(centres, *ci95, color='0.5', alpha=0.25,
                        label='balanced: 95 % Wilson interval')
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel(xlabel)
        ax.set_ylabel('fraction balanced')
        ax.legend()
        ax.grid(alpha=0.3)
    return axes_png(path, draw)


def two_parameter_scatter(path, x, y, balanced, labels, where: str) -> str:
    """Scatter the drives over two parameters (``labels``: the axes): balanced blue, else red."""
    def draw(ax):
        ax.scatter(x[balanced], y[balanced], s=3, c='tab:blue', label='balanced')
        ax.scatter(x[~balanced], y[~balanced], s=3, c='tab:red', label='unbalanced')
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        ax.legend(markerscale=3)
        ax.set_title(f'the two most influential parameters\nbalanced {where}', fontsize=10)
    return axes_png(path, draw)

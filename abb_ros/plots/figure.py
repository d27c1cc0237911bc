"""The one matplotlib set-up of every figure: the Agg backend, imported when drawing.

Figures are PNG files written without a display (a node's host, CI); ``pyplot()`` selects
Agg before pyplot is first imported and returns it, ``save(fig, path)`` writes and closes.
"""

from __future__ import annotations

__all__ = ['DPI', 'axes_png', 'pyplot', 'save']

DPI = 110
"""Resolution of every PNG [dots per inch]."""


def pyplot():
    """Return ``matplotlib.pyplot`` on the Agg backend (no display needed)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def save(fig, path, dpi: int = DPI, file_format: str | None = None) -> str:
    """Lay ``fig`` out, write it to ``path`` and close it; return the path as text.

    ``file_format``: savefig's ``format`` (None: from the suffix of ``path``).
    """
    fig.tight_layout()
    fig.savefig(path, dpi=dpi, format=file_format)
    pyplot().close(fig)
    return str(path)


def axes_png(path, draw, figsize=(6.4, 4.2)) -> str:
    """Draw ``draw(ax)`` on one axes and write it to ``path`` (PNG); return the path."""
    fig, ax = pyplot().subplots(figsize=figsize, dpi=DPI)
    draw(ax)
    return save(fig, path)

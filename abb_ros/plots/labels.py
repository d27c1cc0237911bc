"""Figure titles: the drive's key parameters as mathtext, and titles fitted to the figure.

The parameters are the Eq. (39) ones: wbar, zeta with the washers, epsbar, mbar and n.
:func:`fit_title` breaks a title too wide for its figure into lines that fit.
"""

from __future__ import annotations

import re

SYMBOLS = {'wbar': r'$\bar{\omega}$', 'zeta': r'$\zeta$', 'Dbar': r'$\bar{D}$',
           'epsbar': r'$\bar{\varepsilon}$', 'mbar': r'$\bar{m}$', 'z_P': r'$z_P$ [m]',
           'z_G': r'$z_G$ [m]', 'z_B': r'$z_B$ [m]', 'tau': r'$\tau$ [rad]'}
WASHERS = {'metal': 0.66, 'rubber': 2.53}
"""Washer damping c [kg/s] of the paper's two suspensions (Table 1)."""
WASHER_TOLERANCE = 0.05
"""The paper rounds the rubber washers' zeta = 0.096 to 0.1 (Section 4): 5 % names them."""


def washer_name(c: float) -> str:
    """Return 'metal' or 'rubber' when c is within 5 % of one of the paper's washers, else ''."""
    for name, value in WASHERS.items():
        if abs(c - value) <= WASHER_TOLERANCE * value:
            return name
    return ''


def parameter_text(params, wbar: float | None = None, omit=()) -> str:
    """Return e.g. 'wbar = 2.7, zeta = 0.025 (metal washers), epsbar = 0.0167, mbar = 0.03, n = 2'.

    params : abb_ros.model.parameters.params.DriveParams; ``omit`` names parameters left out (map
    axes). ``n = 0`` is written 'n = 0 (without ABB)' and mbar is left out.
    """
    parts = []
    if wbar is not None and 'wbar' not in omit:
        parts.append(f"{SYMBOLS['wbar']} = {wbar:.3g}")
    if 'zeta' not in omit:
        washers = washer_name(params.c)
        parts.append(f"{SYMBOLS['zeta']} = {params.zeta:.3g}"
                     + (f' ({washers} washers)' if washers else ''))
    if 'epsbar' not in omit:
        parts.append(f"{SYMBOLS['epsbar']} = {params.epsbar:.3g}")
    if params.n == 0:
        return ', '.join(parts + ['n = 0 (without ABB)'])
    if 'mbar' not in omit:
        parts.append(f"{SYMBOLS['mbar']} = {params.mbar:.3g}")
    return ', '.join(parts + [f'n = {params.n}'])


_OUTSIDE_MATH = r'(?=(?:[^$]*\$[^$]*\$)*[^$]*$)'
"""Lookahead: an even number of ``$`` follows, so the place is outside $math$."""


def fit_title(fig, ax, title: str, fontsize: float = 10) -> None:
    """Set ``title`` on ``ax`` so that it fits the width of ``fig``.

    Where it would run off the figure, each of its lines and sentences goes on lines of its
    own; one still too wide is broken after '; ', and a part still too wide after ', '
    (outside $math$ each time), as many parts on a line as fit.
    """
    width = fig.get_figwidth() * fig.dpi * 0.95
    renderer = fig.canvas.get_renderer()

    def fits(text: str) -> bool:
        return ax.set_title(text, fontsize=fontsize).get_window_extent(renderer).width <= width

    def wrapped(text: str, separators: str) -> list[str]:
        if not separators or fits(text):
            return [text]
        lines = []
        for piece in re.split(f'(?<={separators[0]}) ' + _OUTSIDE_MATH, text):
            if lines and fits(f'{lines[-1]} {piece}'):
                lines[-1] = f'{lines[-1]} {piece}'
            else:
                lines.append(piece)
        return [part for line in lines for part in wrapped(line, separators[1:])]

    if fits(title):
        return
    sentences = re.split(r'\n|(?<=\.) (?=[A-Z])' + _OUTSIDE_MATH, title)
    ax.set_title('\n'.join(line for sentence in sentences for line in wrapped(sentence, ';,')),
                 fontsize=fontsize)

"""Figure titles: the drive's key Eq. (39) parameters as matplotlib mathtext.

The parameters are wbar, zeta with the washers, epsbar, mbar and n.
"""

from __future__ import annotations

SYMBOLS = {'wbar': r'$\bar{\omega}$', 'zeta': r'$\zeta$', 'Dbar': r'$\bar{D}$',
           'epsbar': r'$\bar{\varepsilon}$', 'mbar': r'$\bar{m}$'}
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

"""Regenerate the stability maps of Figs. 4-8 in docs/figures (PNG + NPZ data) with `abb-sim map`.

Run from the repository root: ``.venv/bin/python scripts/make_maps.py [--res 160x120] [FIG ...]``
(about a minute on two cores). Every figure goes through the same command a user runs, so
the PNGs document the command line too (printed before each map).
"""

from __future__ import annotations

import argparse
import os
import sys

from abb_ros.cli import main as abb_sim

OUT = os.path.join(os.path.dirname(__file__), '..', 'docs', 'figures')

FIGURES = {
    'fig4a': ['--x', 'wbar', '--y', 'zeta', '--surface'],
    'fig4b': ['--x', 'wbar', '--y', 'zeta'],
    'fig5a': ['--x', 'wbar', '--y', 'Dbar', '--set', 'zeta=0.1'],
    'fig5b': ['--x', 'zeta', '--y', 'Dbar', '--set', 'wbar=2'],
    'fig6': ['--x', 'wbar', '--y', 'epsbar', '--set', 'zeta=0.1'],
    'fig7a': ['--x', 'wbar', '--y', 'mbar', '--set', 'zeta=0.1'],
    'fig7b': ['--x', 'wbar', '--y', 'mbar', '--set', 'zeta=0.025'],
    'fig8': ['--x', 'wbar', '--y', 'mbar', '--set', 'zeta=0.025', '--plane', 'out',
             '--range-x', '0.2:4'],
}


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('figs', nargs='*', default=list(FIGURES))
    ap.add_argument('--res', default='160x120')
    args = ap.parse_args()
    os.makedirs(OUT, exist_ok=True)
    for name in args.figs:
        argv = ['map', *FIGURES[name], '--res', args.res,
                '--out', os.path.join(OUT, f'{name}.png')]
        print('abb-sim ' + ' '.join(argv), flush=True)
        if abb_sim(argv) != 0:
            return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())

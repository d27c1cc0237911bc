"""Regenerate every figure of docs/figures.

The stability maps of Figs. 4-8 (PNG + NPZ data) and the time responses of Figs. 9-16 (PNG in
docs/figures/time).

Run from the repository root, on a shared machine with a lower priority::

    nice -n 10 .venv/bin/python scripts/make_figures.py [--only GROUP] [--res 160x120]
        [--sweep-data DIR] [--replot] [FIGURE ...]

Everything goes through what a user runs: the maps through ``abb-sim map`` (the command line is
printed before each map), the time responses through ``abb-sim run --scenario NAME --out BAG``
(bags in a temporary directory; "without ABB" is ``--set n=0``) and the plot functions of
:mod:`abb_ros.plots.time_response`, which ``abb-sim plot`` uses. ``--replot`` redraws the maps
from their NPZ files without recomputing them; ``--bags DIR`` keeps the runs and reuses them.
Progress goes to stderr. Timings measured: docs/verification.md, 'Regenerating the figures'.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from abb_ros.cli import main as abb_sim

ROOT = Path(__file__).resolve().parent.parent
FIGURES_DIR = ROOT / 'docs' / 'figures'
TIME_DIR = FIGURES_DIR / 'time'

MAPS = {
    'fig4b': ('Fig. 4(b)', ['--x', 'wbar', '--y', 'zeta']),
    'fig4a': ('Fig. 4(a)', ['--x', 'wbar', '--y', 'zeta', '--surface']),
    'fig5a': ('Fig. 5(a)', ['--x', 'wbar', '--y', 'Dbar', '--set', 'zeta=0.1']),
    'fig5b': ('Fig. 5(b)', ['--x', 'zeta', '--y', 'Dbar', '--set', 'wbar=2']),
    'fig6': ('Fig. 6', ['--x', 'wbar', '--y', 'epsbar', '--set', 'zeta=0.1']),
    'fig7a': ('Fig. 7(a)', ['--x', 'wbar', '--y', 'mbar', '--set', 'zeta=0.1']),
    'fig7b': ('Fig. 7(b)', ['--x', 'wbar', '--y', 'mbar', '--set', 'zeta=0.025']),
    # mbar from below mbar_lim (0.0083) to the heavy balls of the parametric resonance.
    'fig8': ('Fig. 8', ['--x', 'wbar', '--y', 'mbar', '--set', 'zeta=0.025', '--plane', 'out',
                        '--range-x', '0.2:4', '--range-y', '0.005:2.5']),
    # ten balls (each of mbar): the balanced family's neutral modes removed (floquet_batch.py)
    'fig7b_n10': ('Fig. 7(b) with n = 10', ['--x', 'wbar', '--y', 'mbar', '--set', 'zeta=0.025',
                                             '--set', 'n=10']),
}
"""Map name -> (paper figure, ``abb-sim map`` arguments)."""

CURVES = {'lambda_vs_speed_n2_n10': (2, 10)}
"""PNG name -> ball counts of |lambda|max(wbar) panels (mbar 0.03 / n per ball, zeta 0.025)."""
SAME_MAP = {'fig4a': 'fig4b'}
"""Fig. 4(a) is the map of Fig. 4(b) drawn as a surface: drawn from its data when made too."""

RUNS = {
    'p1': ('p1', []), 'p2': ('p2', []), 'p3': ('p3', []), 'p3_no_abb': ('p3', ['n=0']),
    'p4': ('p4', []), 'p4_no_abb': ('p4', ['n=0']),
    'p3_n10': ('p3_n10', []), 'p3_n10_scattered': ('p3_n10_scattered', []),
}
"""Run name -> (scenario, ``--set`` values)."""

TIME_FIGURES = {
    'p1_rbar_balls': ('rbar_balls', ('p1',), 'Fig. 9: point P1'),
    'p2_rbar_balls': ('rbar_balls', ('p2',), 'Fig. 10: point P2'),
    'p3_rbar_balls': ('rbar_balls', ('p3',), 'Fig. 11: point P3'),
    'p3_deck_without_abb': ('deck', ('p3_no_abb',), 'Fig. 12: point P3 without the ABB'),
    'p3_deck_with_abb': ('deck', ('p3',), 'Fig. 13: point P3 with the ABB'),
    'p3_with_without_abb': ('comparison', ('p3', 'p3_no_abb'),
                            'Point P3 with and without the ABB, laid out as Fig. 14'),
    'p4_with_without_abb': ('comparison', ('p4', 'p4_no_abb'),
                            'Fig. 14: point P4, imbalance beyond the balls\' capacity'),
    'p3_n10_rbar_balls': ('rbar_balls', ('p3_n10',),
                          'Fig. 15: point P3, n = 10, balls started near +-60 deg'),
    'p3_n10_scattered_rbar_balls': ('rbar_balls', ('p3_n10_scattered',),
                                    'Fig. 16: point P3, n = 10, balls started scattered'),
}
"""PNG name in docs/figures/time -> (kind, runs (with ABB first), title)."""


def _abb_sim(argv) -> dict:
    """``abb-sim ARGV --json`` in-process; its summary (progress bars stay on stderr)."""
    print('  abb-sim ' + ' '.join(argv), file=sys.stderr, flush=True)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = abb_sim([*argv, '--json'])
    if code != 0:
        raise SystemExit(f'abb-sim {argv[0]} failed (exit code {code})')
    return json.loads(out.getvalue())


def load_map(path):
    """Load a :class:`abb_ros.model.stability.floquet.StabilityMap` from an NPZ file of ``abb-sim
    map``."""
    from abb_ros.model.stability.floquet import StabilityMap
    with np.load(path) as data:
        return StabilityMap(str(data['x_name']), str(data['y_name']), data['x_values'],
                            data['y_values'], data['lam_max'], data['status'],
                            str(data['plane']), json.loads(str(data['fixed_json'])),
                            json.loads(str(data['limits_json'])))


def make_maps(names, res, replot) -> None:
    """Compute the named maps with ``abb-sim map`` (or redraw them) and plot them."""
    from abb_ros.plots.maps import map_title, plot_map
    for k, name in enumerate(names, 1):
        figure, args = MAPS[name]
        png = FIGURES_DIR / f'{name}.png'
        print(f'[map {k}/{len(names)}] {name}: {figure}', file=sys.stderr, flush=True)
        same = SAME_MAP.get(name)
        if not replot and same in names[:k - 1]:
            print(f'  the map of {same}, drawn as a surface', file=sys.stderr)
            shutil.copyfile(FIGURES_DIR / f'{same}.npz', png.with_suffix('.npz'))
        elif not replot:
            summary = _abb_sim(['map', *args, '--res', res, '--out', str(png)])
            print(f'  balanced fraction {summary["balanced_fraction"]:.3f}, '
                  f'{summary["wall_s"]:.1f} s', file=sys.stderr)
        smap = load_map(png.with_suffix('.npz'))
        kind = 'surface' if '--surface' in args else 'regions'
        plot_map(smap, png, title=f'{figure}. {map_title(smap)}', kind=kind)


def make_speed_curves() -> None:
    """|lambda|max against wbar for two and ten balls of the same total mass (P3's drive)."""
    from abb_ros.model.parameters.params import DriveParams, apply_settings
    from abb_ros.model.stability.floquet import sweep_speed
    from abb_ros.plots.maps import plot_speed_curves
    wbar = np.linspace(0.2, 3.5, 400)
    for name, counts in CURVES.items():
        curves = []
        for n in counts:
            params, _ = apply_settings(DriveParams(), {'n': n, 'mbar': 0.06 / n,
                                                       'zeta': 0.025})
            omegas = wbar * params.omega0
            curves.append((f'n = {n} (mbar {0.06 / n:.3g} each, {max(n - 2, 0)} neutral '
                           'modes removed)', wbar, sweep_speed(params, omegas, 'in'),
                           sweep_speed(params, omegas, 'out')))
        print(f'[curves] {name}', file=sys.stderr, flush=True)
        plot_speed_curves(curves, FIGURES_DIR / f'{name}.png',
                          title='Largest |Floquet multiplier| against speed, zeta = 0.025, '
                                'total ball mass 0.06 M')


def _title(head, scenario_name, sets):
    """Return the title: the figure, the scenario and its parameters as abb-sim run applies."""
    from abb_ros.commands.shared.inputs import parse_settings
    from abb_ros.io.files.scenario import load_scenario
    from abb_ros.plots.labels import parameter_text
    scenario = load_scenario(scenario_name)
    if sets:
        scenario = scenario.with_settings(parse_settings(sets))
    params = scenario.params
    return (f'{head} (scenario {scenario_name})\n'
            + parameter_text(params, params.wbar(scenario.omega)))


def make_time_responses(names, workdir: Path) -> None:
    """Run the scenarios into bags in ``workdir`` (a bag already there is reused), plot."""
    from abb_ros.io.bag.time_response import load_time_response
    from abb_ros.plots import time_response as plots
    needed = list(dict.fromkeys(run for name in names for run in TIME_FIGURES[name][1]))
    responses = {}
    for k, run in enumerate(needed, 1):
        scenario, sets = RUNS[run]
        print(f'[run {k}/{len(needed)}] {run}', file=sys.stderr, flush=True)
        bag = workdir / run
        argv = ['run', '--scenario', scenario, '--out', str(bag)]
        for s in sets:
            argv += ['--set', s]
        if bag.exists():
            print(f'  reusing {bag}', file=sys.stderr)
        else:
            summary = _abb_sim(argv)
            angles = ', '.join(f'{a:.2f}' for a in summary['ball_angles_deg'])
            print(f'  final rbar {summary["final_rbar"]:.3g}, ball angles [{angles}] deg, '
                  f'real-time factor {summary["real_time_factor"]:.1f}', file=sys.stderr)
        responses[run] = load_time_response(bag)
    TIME_DIR.mkdir(parents=True, exist_ok=True)
    for name in names:
        kind, runs, head = TIME_FIGURES[name]
        title = _title(head, *RUNS[runs[0]])
        out = TIME_DIR / f'{name}.png'
        print(f'[plot] {out.relative_to(FIGURES_DIR.parent.parent)}', file=sys.stderr,
              flush=True)
        if kind == 'rbar_balls':
            plots.plot_rbar_and_balls(responses[runs[0]], out, title)
        elif kind == 'deck':
            plots.plot_deck_coordinates(responses[runs[0]], out, title)
        else:
            plots.plot_abb_comparison(responses[runs[0]], responses[runs[1]], out, title)


def main() -> int:
    """Make the figures the command line asks for; return the exit code."""
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('figures', nargs='*', metavar='FIGURE',
                    help=f'any of {", ".join([*MAPS, *TIME_FIGURES])} (default: all)')
    ap.add_argument('--only', choices=('maps', 'time', 'torque', 'ball_model', 'sweep'),
                    help='only one group: the maps, the time responses, the torque-mode figure '
                         '(scripts/make_torque_figure.py), the ball-model studies '
                         '(scripts/make_ball_model_figures.py, ~30 min) or the sweep report')
    ap.add_argument('--sweep-data', metavar='DIR',
                    help='an `abb-sim sweep config/sweeps/tolerance_p3.yaml` result to redraw '
                         'docs/figures/sweep from (the sweep itself takes ~6 min on 2 idle '
                         'cores; without this option the sweep figures are left as they are)')
    ap.add_argument('--res', default='160x120', help='map grid NxM (default 160x120)')
    ap.add_argument('--replot', action='store_true',
                    help='redraw the maps from their NPZ files, without recomputing')
    ap.add_argument('--bags', metavar='DIR',
                    help='keep the time-response bags in DIR and reuse those already there '
                         '(default: a temporary directory)')
    args = ap.parse_args()
    unknown = [f for f in args.figures if f not in MAPS and f not in TIME_FIGURES]
    if unknown:
        print(f'make_figures.py: error: unknown FIGURE {unknown[0]!r}; valid: '
              f'{", ".join([*MAPS, *TIME_FIGURES])}', file=sys.stderr)
        return 2
    maps = [f for f in (args.figures or MAPS) if f in MAPS and args.only in (None, 'maps')]
    times = [f for f in (args.figures or TIME_FIGURES)
             if f in TIME_FIGURES and args.only in (None, 'time')]
    t0 = time.perf_counter()
    make_maps(maps, args.res, args.replot)
    if not args.figures and args.only in (None, 'maps'):
        make_speed_curves()
    if args.bags:
        Path(args.bags).mkdir(parents=True, exist_ok=True)
        make_time_responses(times, Path(args.bags))
    else:
        with tempfile.TemporaryDirectory(prefix='abb_figures_') as workdir:
            make_time_responses(times, Path(workdir))
    if not args.figures:
        for group, commands in _other_figures(args).items():
            if args.only in (None, group):
                for command in commands:
                    print('$ ' + ' '.join(command[1:]), file=sys.stderr)
                    subprocess.run(command, cwd=ROOT, check=True)
    print(f'{len(maps) + len(times)} figures and the other groups in '
          f'{time.perf_counter() - t0:.0f} s', file=sys.stderr)
    return 0


def _other_figures(args) -> dict:
    """Return the figure groups made by their own scripts, as commands (run from the root)."""
    py = sys.executable
    groups = {'torque': [[py, 'scripts/make_torque_figure.py']],
              'ball_model': [[py, 'scripts/make_ball_model_figures.py', study]
                             for study in ('p1', 'collision', 'rolling', 'spinup')]}
    if args.sweep_data:
        groups['sweep'] = [[py, '-m', 'abb_ros.cli', 'sweep-report', args.sweep_data, '--out',
                            'docs/figures/sweep']]
    return groups


if __name__ == '__main__':
    sys.exit(main())

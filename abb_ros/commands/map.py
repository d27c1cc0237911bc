"""`abb-sim map`: stability map over two Eq. (39) parameters (PNG + NPZ/CSV data file).

Example (Fig. 7b): ``abb-sim map --x wbar --y mbar --set zeta=0.025 --out fig7b.png``.
Progress goes to stderr (tqdm); the summary (and --json) to stdout. Both files are written under
temporary names and renamed together at the end, so a failed write leaves neither behind.
"""

from __future__ import annotations

import sys

import numpy as np

from abb_ros.commands.shared.errors import CommandFailed, UsageError
from abb_ros.commands.shared.inputs import drive_params, parse_settings
from abb_ros.commands.shared.outputs import check_output, output_files
from abb_ros.model.parameters.params import ParamError

DEFAULT_RANGES = {'wbar': (0.2, 3.5), 'zeta': (0.0, 0.15), 'Dbar': (0.0, 1.0),
                  'epsbar': (0.0, 0.05), 'mbar': (0.001, 0.12), 'z_P': (-0.01, 0.01),
                  'z_G': (-0.005, 0.005), 'z_B': (-0.005, 0.005), 'tau': (-0.01, 0.01)}
"""Axis ranges when --range-x/--range-y are not given (those of the paper's figures; heights
[m] and the lean [rad] of docs/equations.md F4, F6 around an optical drive's); its keys are the
axes a map may vary (floquet.MAP_AXES, not imported here: the parser starts fast)."""
OUT_OF_PLANE_MBAR = (0.01, 2.5)
"""Fig. 8 needs heavy balls to show the parametric-resonance zone."""
MAX_POINTS = 1_000_000
MAX_MEMBERS = 64
"""Most sampled family members per point (floquet.MAX_MEMBERS)."""
DATA_SUFFIXES = ('.npz', '.csv')
IMAGE_SUFFIXES = ('.png', '.pdf', '.svg')


def add_arguments(parser) -> None:
    """Add the options of `abb-sim map` to ``parser``."""
    parser.add_argument('--x', required=True, choices=tuple(DEFAULT_RANGES),
                        help='horizontal axis')
    parser.add_argument('--y', required=True, choices=tuple(DEFAULT_RANGES),
                        help='vertical axis')
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='fixed parameter (SI or Eq. 39 name); others are Table 1 values')
    parser.add_argument('--config', help='ROS 2 parameter file with drive.* parameters')
    parser.add_argument('--res', default='120x100', help='grid NxM (x points by y points)')
    parser.add_argument('--plane', choices=('in', 'out', 'coupled'), default='in',
                        help='in-plane or out-of-plane group, or the coupled linearisation '
                        '(lam_max over a spindle period; the plane of any map with heights)')
    parser.add_argument('--range-x', help='lo:hi of the x axis')
    parser.add_argument('--range-y', help='lo:hi of the y axis')
    parser.add_argument('--surface', action='store_true',
                        help='draw |lambda|max as a 3-D surface (Fig. 4a) instead of regions')
    parser.add_argument('--data', help='data file (.npz or .csv); default: --out with .npz')
    parser.add_argument('--out', required=True, help='PNG (or .pdf, .svg) file to write')
    parser.add_argument('--members', type=int, default=0, metavar='K',
                        help='also the best and worst |lambda|max over K sampled members of '
                        'the balanced family per point (n >= 3: can these balls balance here '
                        'at all); default 0: the symmetric fan only')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')


def _range(text, axis, plane):
    if text is None:
        if axis == 'mbar' and plane == 'out':
            return OUT_OF_PLANE_MBAR
        return DEFAULT_RANGES[axis]
    try:
        lo, hi = (float(v) for v in text.split(':'))
    except ValueError:
        raise UsageError(f'range of {axis} must be lo:hi, got {text!r}') from None
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise ParamError(f'range-{axis}', text, 'lo:hi with lo < hi, finite')
    return lo, hi


def _res(text):
    try:
        nx, ny = (int(v) for v in text.lower().split('x'))
    except ValueError:
        raise UsageError(f'--res must be NxM, got {text!r}') from None
    if nx < 2 or ny < 2 or nx * ny > MAX_POINTS:
        raise ParamError('res', text, f'NxM with N, M >= 2 and N*M <= {MAX_POINTS}')
    return nx, ny


def _check_axes(args, settings, base, xs, ys):
    """Refuse a --set of a swept axis, and axis ends that make no valid drive, before work."""
    from abb_ros.model.parameters.params import apply_settings
    for flag, axis in (('--x', args.x), ('--y', args.y)):
        for key in ((axis, 'omega') if axis == 'wbar' else (axis,)):
            if key in settings:
                raise UsageError(f'--set {key}: {axis} is the map\'s {flag} axis (swept over '
                                 f'--range-{flag[2:]}); give a fixed value only to another '
                                 'parameter')
    apply_settings(base, settings)    # a fixed value out of range names itself, not an axis
    for axis, values, flag in ((args.x, xs, '--range-x'), (args.y, ys, '--range-y')):
        for end in (values[0], values[-1]):
            try:
                apply_settings(base, {**settings, axis: float(end)})
            except ParamError as exc:
                raise UsageError(f'{flag} {values[0]:g}:{values[-1]:g}: at {axis} = {end:g}, '
                                 f'{exc}') from None


def run(args) -> dict:
    """Compute the stability map, write the figure and the data file; return the summary."""
    import time

    from tqdm import tqdm

    from abb_ros.io.files.map_file import save_map
    from abb_ros.model.stability.floquet import stability_map
    from abb_ros.plots.maps import plot_map
    if args.x == args.y:
        raise UsageError('--x and --y must differ')
    nx, ny = _res(args.res)
    out = check_output('--out', args.out, IMAGE_SUFFIXES)
    data = check_output('--data', args.data or out.with_suffix('.npz'), DATA_SUFFIXES)
    xs = np.linspace(*_range(args.range_x, args.x, args.plane), nx)
    ys = np.linspace(*_range(args.range_y, args.y, args.plane), ny)
    if not 0 <= args.members <= MAX_MEMBERS:
        raise ParamError('members', args.members, f'[0, {MAX_MEMBERS}]')
    base = drive_params(args.config)
    settings = parse_settings(args.set, 'map')
    _check_axes(args, settings, base, xs, ys)
    t0 = time.perf_counter()
    with tqdm(total=nx * ny * (2 if args.members else 1), unit='pt', file=sys.stderr,
              disable=args.no_progress, desc=f'{args.plane} map') as bar:
        try:
            smap = stability_map(base, args.x, xs, args.y, ys, settings, args.plane,
                                 bar.update, args.members)
        except ParamError as exc:
            if exc.name != 'omega':
                raise
            raise UsageError(f'the map\'s slowest speed: {exc}; raise the low end of the '
                             'wbar range (--range-x/--range-y) or --set wbar') from None
    wall = time.perf_counter() - t0
    try:
        with output_files(data, out) as (data_tmp, out_tmp):
            save_map(smap, data_tmp)
            plot_map(smap, out_tmp, kind='surface' if args.surface else 'regions')
    except OSError as exc:
        raise CommandFailed(f'writing {data} and {out} failed ({exc.strerror or exc}); '
                            'neither was written') from None
    return {**smap.summary(), 'png': str(out), 'data': str(data), 'wall_s': wall}

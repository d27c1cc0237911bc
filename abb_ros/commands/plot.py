"""`abb-sim plot BAG --out DIR [--compare BAG2]`: the paper's time-response figures (PNG).

The bags are read before anything is written; the figures are written under temporary names
and renamed together, so a failure leaves no figure (and no folder this command created).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from abb_ros.io.bag.writer import BagError


def add_arguments(parser) -> None:
    """Add the options of `abb-sim plot` to ``parser``."""
    parser.add_argument('bag', help='bag directory or .mcap file (abb-sim run, recorder, '
                                    'ros2 bag record)')
    parser.add_argument('--out', required=True, help='directory for the PNG files')
    parser.add_argument('--compare', metavar='BAG2',
                        help='the same case without the ABB: adds Fig. 14 (overlay) and '
                             "Fig. 12 (its deck coordinates)")
    parser.add_argument('--R', type=float, default=None,
                        help='race radius [m] for rbar when the bag does not store the drive '
                             'parameters (default: Table 1, 0.015 m)')
    parser.add_argument('--title', default='', help='figure title')


def run(args) -> dict:
    """Read the bag(s), write the time-response figures; return the summary."""
    from abb_ros.commands.shared.errors import CommandFailed, UsageError
    from abb_ros.commands.shared.outputs import check_output, output_files
    from abb_ros.io.bag.time_response import TimeResponseError, load_time_response
    from abb_ros.model.dynamics.state import wrap_degrees
    from abb_ros.plots import time_response as plots

    if args.R is not None and not (args.R > 0 and np.isfinite(args.R)):
        raise UsageError(f'--R must be a finite radius > 0 m, got {args.R}')
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f'--out {out}: exists and is not a directory')
    check_output('--out', out / 'rbar_balls.png')
    try:
        resp = load_time_response(args.bag, R=args.R)
        other = (load_time_response(args.compare, R=args.R)
                 if args.compare else None)
    except (BagError, TimeResponseError, OSError) as exc:
        raise UsageError(str(exc)) from None
    figures = [out / 'rbar_balls.png', out / 'deck.png']
    if other is not None:
        figures += [out / 'deck_without_abb.png', out / 'abb_comparison.png']
    created = not out.exists()
    try:
        with output_files(*figures) as temps:
            plots.plot_rbar_and_balls(resp, temps[0], args.title)
            plots.plot_deck_coordinates(resp, temps[1], args.title)
            if other is not None:
                plots.plot_deck_coordinates(other, temps[2],
                                            f'{args.title} (without ABB)'.strip())
                plots.plot_abb_comparison(resp, other, temps[3], args.title)
    except OSError as exc:
        if created:
            shutil.rmtree(out, ignore_errors=True)
        raise CommandFailed(f'writing the figures to {out} failed ({exc.strerror or exc}); '
                            'none was written') from None
    summary = {
        'figures': [str(f) for f in figures],
        'R_m': resp.R, 'R_source': resp.R_source,
        'duration_s': float(resp.t_pose[-1]) if len(resp.t_pose) else 0.0,
        'final_rbar': float(resp.rbar[-1]),
        'n_balls': int(resp.phi.shape[0]) if resp.phi.size else 0,
        'final_ball_angles_deg': (wrap_degrees(resp.phi[:, -1]).tolist()
                                  if resp.phi.size else []),
    }
    if other is not None:
        summary['final_rbar_without_abb'] = float(other.rbar[-1])
        summary['max_rbar_last_tenth'] = _tail_max(resp)
        summary['max_rbar_last_tenth_without_abb'] = _tail_max(other)
    return summary


def _tail_max(resp) -> float:
    """Return the largest rbar over the last tenth of the run (residual vibration, Fig. 14)."""
    rbar = resp.rbar
    return float(np.max(rbar[len(rbar) * 9 // 10:]))

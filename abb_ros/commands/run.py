"""`abb-sim run`: a scenario integrated headless (no DDS), optionally written to a bag."""

from __future__ import annotations

import sys

import numpy as np

from abb_ros.model.params import DriveParams

DEFAULT_SCENARIO = 'p3'


def add_arguments(parser):
    parser.add_argument('--config', help='ROS 2 parameter file with drive.* parameters '
                        '(default: Table 1, config/cdrom_table1.yaml)')
    parser.add_argument('--scenario', default=DEFAULT_SCENARIO,
                        help='p1, p2, p3, p4, p3_n10, p3_n10_scattered, spinup_p1_p3 or a YAML '
                        'file (default: %(default)s)')
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='SI (k, c, eps, m, n, omega, ...) or Eq. (39) name (wbar, zeta, '
                        'Dbar, epsbar, mbar); repeatable')
    parser.add_argument('--duration', type=float, help='simulated seconds (default: scenario)')
    parser.add_argument('--out', help='write a rosbag2 MCAP directory here')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing --out')
    parser.add_argument('--no-abb', action='store_true', help='the drive without balls (n = 0)')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')


def _wrap_deg(phi):
    return ((np.degrees(phi) + 180.0) % 360.0) - 180.0


def run(args) -> dict:
    from abb_ros.commands.api import UsageError, parse_settings
    from abb_ros.app.headless import run_scenario
    from abb_ros.io.scenario import load_scenario
    from abb_ros.model.params import ParamError

    base = DriveParams.from_yaml(args.config) if args.config else None
    scenario = load_scenario(args.scenario, base=base)
    settings = parse_settings(args.set)
    if args.no_abb:
        settings['n'] = 0
    if settings:
        scenario = scenario.with_settings(settings)
    if args.duration is not None:
        if not (np.isfinite(args.duration) and args.duration > 0):
            raise ParamError('duration', args.duration, '(0, inf) s')
        scenario.duration = float(args.duration)
    bag = None
    if args.out:
        from abb_ros.io.bag_writer import BagError, BagWriter
        try:
            bag = BagWriter(args.out, overwrite=args.overwrite)
        except (BagError, FileExistsError) as exc:
            raise UsageError(f'--out {args.out}: {exc}'.replace('pass overwrite=True',
                                                                 'pass --overwrite')) from None
        bag.set_drive_params(scenario.params)
    bar = None
    if not args.no_progress:
        from tqdm import tqdm
        bar = tqdm(total=round(scenario.duration, 6), unit='sim s', file=sys.stderr,
                   desc=f'abb-sim run {scenario.name}', leave=False,
                   bar_format='{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]')
    try:
        result = run_scenario(scenario, bag=bag, progress=bar.update if bar else None)
    finally:
        if bar is not None:
            bar.close()
        if bag is not None:
            bag.close()
    p = scenario.params
    y = result.y[-1]
    N = 7 + p.n
    summary = {
        'scenario': scenario.name,
        'n': p.n,
        'wbar': float(y[N] / p.omega0),
        'omega_rad_s': float(y[N]),
        'duration_s': float(result.t[-1] - result.t[0]),
        'final_rbar': float(np.sqrt(y[1] ** 2 + y[2] ** 2 + y[3] ** 2) / p.R),
        'ball_angles_deg': [round(float(a), 3) for a in _wrap_deg(y[7:N])],
        'wall_time_s': round(result.wall_time, 4),
        'real_time_factor': round(result.real_time_factor, 2),
        'compile_time_s': round(result.compile_time, 3),
    }
    if p.beyond_paper:
        summary['beyond_paper'] = list(p.beyond_paper)
    if result.refined_steps:
        summary['contact_refined_steps'] = result.refined_steps
        summary['contact_max_substeps'] = result.max_substeps
    if args.out:
        summary['bag'] = str(args.out)
        summary['messages'] = result.messages
    return summary

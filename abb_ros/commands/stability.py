"""`abb-sim stability`: the largest |Floquet multiplier| at one operating point.

The spindle speed is given with ``--set wbar=...`` or ``--set omega=...`` [rad/s]; other
parameters default to Table 1 (config/cdrom_table1.yaml values). ``lam_max`` is over one
spindle period T = 2 pi / omega of the whole linearisation: in the paper's plane the larger of
the in-plane group's value and the square of the out-of-plane group's (its period is T / 2),
both kept beside it; with heights (docs/equations.md F4) the coupled linearisation's, with the
residual tilt it predicts and the second race that would remove it.
"""

from __future__ import annotations

import math

from abb_ros.commands.shared.errors import UsageError
from abb_ros.commands.shared.inputs import drive_params, parse_settings
from abb_ros.model.parameters.params import ParamError, apply_settings


def add_arguments(parser) -> None:
    """Add the options of `abb-sim stability` to ``parser``."""
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='parameter (SI name, omega, or wbar/zeta/Dbar/epsbar/mbar/n)')
    parser.add_argument('--config', help='ROS 2 parameter file with drive.* parameters')
    parser.add_argument('--phi-star', help='the member of the balanced family to evaluate: ball '
                        'angles phi_i* in degrees, comma separated (must satisfy Eq. 26); '
                        'default: the symmetric fan')


def operating_point(args):
    """Return (DriveParams, omega) from --config and --set; omega is required."""
    base = drive_params(args.config)
    params, omega = apply_settings(base, parse_settings(args.set, 'stability'))
    if omega is None:
        raise UsageError('give the spindle speed with --set wbar=... or --set omega=... [rad/s]')
    if omega <= 0:
        raise ParamError('omega', omega, '(0, inf) rad/s')
    return params, omega


def run(args) -> dict:
    """Return the verdict and both planes' |lambda|max at the operating point."""
    from abb_ros.model.stability.floquet import point_stability
    params, omega = operating_point(args)
    phi = None
    if args.phi_star:
        try:
            phi = [math.radians(float(v)) for v in args.phi_star.split(',')]
        except ValueError:
            raise ParamError('phi_star', args.phi_star, 'comma-separated degrees') from None
    res = point_stability(params, omega, phi)
    out = {'omega_rad_s': omega, 'wbar': params.wbar(omega), **params.dimensionless(),
           'verdict': res.verdict, 'balanced': res.balanced,
           'balanced_equilibrium_exists': res.exists,
           'phi_star_deg': [math.degrees(v) for v in res.phi_star], 'member': res.member}
    if params.beyond_paper:
        out['note'] = ('linear analysis of the paper\'s model: it ignores '
                       + ', '.join(params.beyond_paper)
                       + ' (docs/ball_size_contact_rolling.md); the time simulation has them')
        if params.contact_E > 0 and params.n > 1:
            out['note'] += ('; the balls\' size does bound the balanced equilibrium (their '
                            'capacity and spacing, docs/verification.md)')
    if res.exists:
        out['lam_max'] = res.lam_max
        if not res.coupled:
            out['lam_max_in_plane'] = res.lam_in
            out['lam_max_out_of_plane'] = res.lam_out
        out['neutral_modes_removed'] = res.neutral
        out['family_invariance'] = res.invariance
    else:
        out['reason'] = res.reason
    if params.race2_n:
        out['race2_n'] = params.race2_n
    if params.off_plane:
        out.update(_two_plane(params, res))
    return out


def _two_plane(params, res) -> dict:
    """Return the coupled analysis' extras: residual tilt, couple, the mirrored second race."""
    from abb_ros.model.stability import two_plane
    out = {'linearisation': 'coupled (mass centres off the washers\' plane, a leaning '
                            'rotor axis or a second race, docs/equations.md F4-F7)',
           'residual_couple_kg_m2': abs(two_plane.couple_left(params))}
    if res.exists:
        out['residual_tilt_rad'] = res.residual_tilt
    race = two_plane.second_race(params)
    if race:
        out['second_race'] = race.get('why', race)
    return out

"""`abb-sim freqs`: natural frequencies [rad/s] of Eqs. (27)-(32) with m = omega = 0.

With heights (docs/equations.md F4) those of the coupled deck (model/stability/coupled.py).
"""

from __future__ import annotations

from abb_ros.commands.shared.inputs import drive_params, parse_settings
from abb_ros.model.parameters.params import apply_settings

PAPER = {'X': 298.0, 'Y': 298.0, 'Z': 298.0, 'alpha': 535.0, 'beta': 750.0, 'gamma': 577.0}
"""Section 4 of the paper (omega0 ~ 298 rad/s for X, Y, Z), for comparison in the output."""


def add_arguments(parser) -> None:
    """Add the options of `abb-sim freqs` to ``parser``."""
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='parameter (SI name or Eq. 39 name)')
    parser.add_argument('--config', help='ROS 2 parameter file with drive.* parameters')


def run(args) -> dict:
    """Return the drive's natural frequencies [rad/s] beside the paper's."""
    from abb_ros.model.stability.coupled import deck_natural_frequencies
    base = drive_params(args.config)
    params, _ = apply_settings(base, parse_settings(args.set, 'freqs'))
    freqs = deck_natural_frequencies(params)
    out = {f'omega_{k}_rad_s': v for k, v in freqs.items()}
    out['omega0_rad_s'] = params.omega0
    out['paper_rad_s'] = PAPER
    return out

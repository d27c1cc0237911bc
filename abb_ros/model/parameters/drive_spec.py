"""The drive's parameters (Table 1 of Kim, Lee & Chung 2005, SI), one ParamSpec each.

:class:`abb_ros.model.parameters.params.DriveParams` takes its fields, defaults and checks from
:data:`DRIVE_SPECS`; the nodes declare them as ``drive.*``, the ``abb-sim`` subcommands take
them with ``--set`` (without ``drive.``).
"""

from __future__ import annotations

import math

from abb_ros.model.parameters.param_spec import DRIVE_PREFIX, INTEGER, ParamSpec

__all__ = ['DRIVE_SPECS', 'HEIGHTS', 'OFF_PLANE', 'MAX_BALLS', 'RUBBER_C', 'METAL_C', 'SPAN',
           'SPEED_SPEC', 'MAX_OMEGA', 'CLAMPED_DECK']

RUBBER_C = 2.53
"""Washer damping c of rubber suspension washers [kg/s] (Table 1)."""
METAL_C = 0.66
"""Washer damping c of metal suspension washers [kg/s] (Table 1)."""
MAX_BALLS = 64
"""Largest ball count accepted (the race of a real drive holds about 10)."""


SPAN = 1e6
"""How far a drive parameter may stray from its Table 1 value, each way: a factor of a
million. Every drive of the paper, of the scenarios and of the sweeps lies well within, as
does any optical drive (a washer stiffness of 4 mN/m to 4 GN/m, a ball of 0.4 ug to 0.4 kg);
beyond it the linear algebra of the analysis loses its digits and the step of the integrator
its meaning, so such a value is refused rather than computed."""

MAX_OMEGA = 1.0e5
"""Fastest spindle speed accepted anywhere [rad/s] (about a million rpm, 60 times the fastest
optical drive): ``omega`` and the speeds ``wbar`` stands for."""

CLAMPED_DECK = 1.0e10
"""Highest deck mass [kg] and deck inertia [kg m^2]: beyond SPAN, so that a deck made
immovable by its mass (``ball_materials.HEAVY`` = 1e9, the clamped race of the contact
tests) stays a valid drive."""

SPEED_SPEC = ParamSpec('omega', None, 'rad/s', 'spindle speed of an operating point (or wbar '
                       'omega0); 0 stops the spindle; no default: the analysis needs it', low=0.0,
                       high=MAX_OMEGA)
"""The spindle speed of an operating point (``--set omega=`` or ``wbar=``)."""


def _drive(name, default, unit, description, ref=None, **kw):
    """Return the spec of drive parameter ``name``: (0 or SPAN^-1 ref, SPAN ref].

    ``ref`` is the typical value (default: ``default``, the Table 1 value); without a
    ``low`` the range starts at ``ref / SPAN``.
    """
    ref = default if ref is None else ref
    kw.setdefault('low', ref / SPAN)
    kw.setdefault('high', ref * SPAN)
    return ParamSpec(DRIVE_PREFIX + name, default, unit, description,
                     applies='at the next step', **kw)


_NONNEG = dict(low=0.0)

DRIVE_SPECS = (
    _drive('a', 0.070, 'm', 'width of the feeding deck, a'),
    _drive('b', 0.110, 'm', 'length of the feeding deck, b'),
    _drive('d', 0.030, 'm', 'distance between C (spindle axis) and P (deck mass centre), d',
           low=-1.0, high=1.0),
    _drive('R', 0.015, 'm', 'mean (pitch) radius of the ball race, R'),
    _drive('M_P', 0.150, 'kg', 'mass of the feeding-deck assembly, M_P',
           high=CLAMPED_DECK),
    _drive('M', 0.026, 'kg', 'mass of the equivalent rotor, M'),
    _drive('m', 0.43e-3, 'kg', 'mass of one balancing ball, m'),
    _drive('J_Px', 1.43e-4, 'kg m^2', 'deck moment of inertia about x through P, J_Px',
           high=CLAMPED_DECK),
    _drive('J_Py', 0.31e-4, 'kg m^2', 'deck moment of inertia about y through P, J_Py',
           high=CLAMPED_DECK),
    _drive('J_Pz', 1.74e-4, 'kg m^2', 'deck moment of inertia about z through P, J_Pz',
           high=CLAMPED_DECK),
    _drive('J_x', 1.46e-6, 'kg m^2', 'rotor moment of inertia about x, J_x'),
    _drive('J_y', 1.46e-6, 'kg m^2', 'rotor moment of inertia about y, J_y (equal to J_x)'),
    _drive('J_z', 2.93e-6, 'kg m^2', 'rotor moment of inertia about the spin axis z, J_z'),
    _drive('k', 3972.0, 'N/m', 'stiffness of one suspension washer, k'),
    _drive('c', RUBBER_C, 'kg/s', 'damping of one suspension washer, c (rubber 2.53, metal '
           '0.66)', **_NONNEG),
    _drive('D', 5e-6, 'kg m^2/s', 'viscous drag coefficient of one ball in the race fluid, D',
           **_NONNEG),
    _drive('eps', 0.25e-3, 'm', 'mass eccentricity of the rotor, epsilon', **_NONNEG),
    ParamSpec('drive.n', 2, '', 'number of balancing balls, n (0 = drive without ABB)',
              INTEGER, 0, MAX_BALLS, applies='on ~/reset (simulator)'),
    # ---- ball size, contact, rolling (docs/ball_size_contact_rolling.md); zero = the paper ----
    _drive('r_ball', 0.0, 'm', 'ball radius (0 = point balls, the paper); needed by contact '
           'and rolling resistance; less than R', ref=2.873e-3, **_NONNEG),
    _drive('contact_E', 0.0, 'Pa', "Young's modulus of the balls for the Hertzian ball-ball "
           'contact (0 = balls pass through each other, the paper; steel 2.0e11)', ref=2.0e11,
           high=1.0e13, **_NONNEG),
    _drive('contact_nu', 0.3, '', "Poisson's ratio of the balls (steel 0.3)", low=0.0,
           high=0.5),
    _drive('contact_damping', 0.0, 's/m', 'Hunt-Crossley damping factor chi of the ball-ball '
           "contact: F = K delta^1.5 (1 + chi delta')", ref=0.1, **_NONNEG),
    _drive('rolling_mu', 0.0, 'm', 'rolling-resistance coefficient (lever arm) between ball '
           'and race (0 = none, the paper)', ref=1e-6, high=1.0, **_NONNEG),
    _drive('rolling_stick_rate', 1e-3, 'rad/s', 'least half-width of the Karnopp stick band '
           "of rolling resistance in phi_i' (the band is at least the speed rolling resistance "
           'takes away in 1 ms)'),
    ParamSpec('drive.ball_rotation', 0, '', '1 = the balls roll on the race (their spin '
              'inertia 2/5 m r_ball^2 adds 2/5 m R^2 to the ball mass term), 0 = the paper',
              INTEGER, 0, 1, applies='at the next step'),
    # ---- mass centres off the deck's plane (docs/equations.md, F4); zero = the paper ----
    _drive('z_P', 0.0, 'm', "height of the deck's mass centre P above the plane of the four "
           'washer attachment points (which contains C); 0 = the paper', ref=0.01, low=-1.0,
           high=1.0),
    _drive('z_G', 0.0, 'm', "height of the rotor's mass centre G above that plane; z_G != z_B "
           'makes a couple the balls cannot cancel; 0 = the paper', ref=0.01, low=-1.0,
           high=1.0),
    _drive('z_B', 0.0, 'm', "height of the balls' race above that plane; 0 = the paper",
           ref=0.01, low=-1.0, high=1.0),
    # ---- couple (dynamic) imbalance: the rotor's principal axis leans (F6); 0 = the paper ----
    _drive('tau', 0.0, 'rad', "lean of the rotor's principal axis from the spin axis (couple "
           'imbalance, the rotating moment (J_z - J_x) sin tau cos tau omega^2); 0 = the paper',
           ref=0.01, low=-0.5, high=0.5),
    _drive('psi_tau', 0.0, 'rad', "rotor-fixed direction, from G's, toward which the +z end of "
           'the leaning axis points (no effect while tau = 0)', ref=1.0, low=-2 * math.pi,
           high=2 * math.pi),
    # ---- a second race (two-plane balancing, docs/equations.md F7); race2.n 0 = none ----
    ParamSpec('drive.race2.n', 0, '', 'number of balls in a second race (0 = none, the paper); '
              "their angles follow race 1's in every output", INTEGER, 0, MAX_BALLS,
              applies='on ~/reset (simulator)'),
    _drive('race2.m', 0.0, 'kg', "mass of one ball of the second race (0 = race 1's m; "
           "otherwise within m's range)", ref=0.43e-3, **_NONNEG),
    _drive('race2.R', 0.0, 'm', "pitch radius of the second race (0 = race 1's R; otherwise "
           "within R's range)", ref=0.015, **_NONNEG),
    _drive('race2.D', 0.0, 'kg m^2/s', "viscous drag of one ball of the second race (0 = race "
           "1's D)", ref=5e-6, **_NONNEG),
    _drive('race2.z', 0.0, 'm', "height of the second race above the washers' plane (two-plane "
           'balancing: on the other side of G from race 1)', ref=0.01, low=-1.0, high=1.0),
)
"""The physical parameters of Table 1 (rubber washers, eps = 0.25 mm, n = 2), SI, and the
optional terms beyond the paper (zero = the paper's model)."""

HEIGHTS = ('z_P', 'z_G', 'z_B')
"""The heights of P, G and the race above the washers' plane (all zero: the paper's plane)."""

OFF_PLANE = HEIGHTS + ('tau', 'race2.n')
"""What takes a drive out of the paper's plane model: the heights, the leaning rotor axis and a
second race; nonzero, the groups of Eqs. (27)-(33) couple."""

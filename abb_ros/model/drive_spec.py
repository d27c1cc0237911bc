"""The drive's parameters (Table 1 of Kim, Lee & Chung 2005, SI), one ParamSpec each.

:class:`abb_ros.model.params.DriveParams` takes its fields, defaults and checks from
:data:`DRIVE_SPECS`; the simulator, the analysis node and the example controller declare them
as ``drive.*``, and every ``abb-sim`` subcommand takes them with ``--set`` (without
``drive.``).
"""

from __future__ import annotations

from abb_ros.model.param_spec import COMMANDS, DRIVE_PREFIX, INTEGER, ParamSpec

__all__ = ['DRIVE_SPECS', 'DRIVE_NODES', 'MAX_BALLS', 'RUBBER_C', 'METAL_C']

RUBBER_C = 2.53
"""Washer damping c of rubber suspension washers [kg/s] (Table 1)."""
METAL_C = 0.66
"""Washer damping c of metal suspension washers [kg/s] (Table 1)."""
MAX_BALLS = 64
"""Largest ball count accepted (the race of a real drive holds about 10)."""

DRIVE_NODES = ('simulator', 'analysis', 'spin_controller')
"""The nodes that take the drive's parameters (and max_spindle_speed)."""


def _drive(name, default, unit, description, **kw):
    kw.setdefault('low', 0.0)
    kw.setdefault('low_open', True)
    return ParamSpec(DRIVE_PREFIX + name, default, unit, description, nodes=DRIVE_NODES,
                     commands=COMMANDS, applies='at the next step', **kw)


_NONNEG = dict(low=0.0, low_open=False)

DRIVE_SPECS = (
    _drive('a', 0.070, 'm', 'width of the feeding deck, a'),
    _drive('b', 0.110, 'm', 'length of the feeding deck, b'),
    _drive('d', 0.030, 'm', 'distance between C (spindle axis) and P (deck mass centre), d',
           low=-1.0, low_open=False, high=1.0),
    _drive('R', 0.015, 'm', 'mean (pitch) radius of the ball race, R'),
    _drive('M_P', 0.150, 'kg', 'mass of the feeding-deck assembly, M_P'),
    _drive('M', 0.026, 'kg', 'mass of the equivalent rotor, M'),
    _drive('m', 0.43e-3, 'kg', 'mass of one balancing ball, m'),
    _drive('J_Px', 1.43e-4, 'kg m^2', 'deck moment of inertia about x through P, J_Px'),
    _drive('J_Py', 0.31e-4, 'kg m^2', 'deck moment of inertia about y through P, J_Py'),
    _drive('J_Pz', 1.74e-4, 'kg m^2', 'deck moment of inertia about z through P, J_Pz'),
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
              INTEGER, 0, MAX_BALLS, applies='on ~/reset (simulator)', nodes=DRIVE_NODES,
              commands=COMMANDS),
    # ---- ball size, contact, rolling (docs/ball_size_contact_rolling.md); zero = the paper ----
    _drive('r_ball', 0.0, 'm', 'ball radius (0 = point balls, the paper); needed by contact '
           'and rolling resistance', **_NONNEG),
    _drive('contact_E', 0.0, 'Pa', "Young's modulus of the balls for the Hertzian ball-ball "
           'contact (0 = balls pass through each other, the paper; steel 2.0e11)', **_NONNEG),
    _drive('contact_nu', 0.3, '', "Poisson's ratio of the balls (steel 0.3)", low=0.0,
           low_open=False, high=0.5),
    _drive('contact_damping', 0.0, 's/m', 'Hunt-Crossley damping factor chi of the ball-ball '
           "contact: F = K delta^1.5 (1 + chi delta')", **_NONNEG),
    _drive('rolling_mu', 0.0, 'm', 'rolling-resistance coefficient (lever arm) between ball '
           'and race (0 = none, the paper)', **_NONNEG),
    _drive('rolling_stick_rate', 1e-3, 'rad/s', 'least half-width of the Karnopp stick band '
           "of rolling resistance in phi_i' (the band is at least the speed rolling resistance "
           'takes away in 1 ms)'),
    ParamSpec('drive.ball_rotation', 0, '', '1 = the balls roll on the race (their spin '
              'inertia 2/5 m r_ball^2 adds 2/5 m R^2 to the ball mass term), 0 = the paper',
              INTEGER, 0, 1, applies='at the next step', nodes=DRIVE_NODES, commands=COMMANDS),
)
"""The physical parameters of Table 1 (rubber washers, eps = 0.25 mm, n = 2), SI, and the
optional terms beyond the paper (zero = the paper's model)."""

"""Steel balls of finite size: material presets and a clamped race.

The terms themselves live in :mod:`abb_ros.model.dynamics.kernels`
(``ball_size.add_ball_rotation``, ``contact.contact_forces``, ``rolling_resistance.accel_rolling``,
``contact_steps.contact_substeps``) and are switched on by the
DriveParams fields ``r_ball``, ``contact_E``, ``contact_nu``, ``contact_damping``,
``rolling_mu``, ``rolling_stick_rate`` and ``ball_rotation`` (all zero: the paper's model).
docs/ball_size_contact_rolling.md states the laws, the assumptions and the measurements.
"""

from __future__ import annotations

import math

from abb_ros.model.parameters.params import DriveParams

__all__ = ['STEEL_DENSITY', 'STEEL_E', 'STEEL_NU', 'steel_ball_radius', 'with_steel_balls',
           'HEAVY', 'clamped_race']

STEEL_DENSITY = 7850.0
"""Density of bearing steel [kg/m^3]."""
STEEL_E = 2.0e11
"""Young's modulus of bearing steel [Pa]."""
STEEL_NU = 0.3
"""Poisson's ratio of bearing steel."""


def steel_ball_radius(m: float) -> float:
    """Radius [m] of a solid steel ball of mass m [kg]: (3 m / (4 pi rho))^(1/3)."""
    return (3.0 * m / (4.0 * math.pi * STEEL_DENSITY)) ** (1.0 / 3.0)


def with_steel_balls(params: DriveParams, contact: bool = True, rolling_mu: float = 0.0,
                     rotation: bool = False, contact_damping: float = 0.0) -> DriveParams:
    """Return ``params`` with solid steel balls of its mass m.

    Radius from the density, Hertzian contact (if ``contact``), rolling resistance
    ``rolling_mu`` [m], rolling-ball spin inertia (if ``rotation``).
    """
    return params.replace(r_ball=steel_ball_radius(params.m),
                          contact_E=STEEL_E if contact else 0.0, contact_nu=STEEL_NU,
                          contact_damping=contact_damping, rolling_mu=rolling_mu,
                          ball_rotation=int(rotation))


HEAVY = 1e9
"""Mass [kg] and inertia [kg m^2] of an immovable deck (:func:`clamped_race`)."""


def clamped_race(n: int = 2, m: float = 0.78e-3, **changes) -> DriveParams:
    """Return the parameters of steel balls on a race whose deck cannot move.

    Deck mass and inertias HEAVY, rotor without eccentricity and without drag unless given.
    The balls' forces move the deck by
    ~1e-13 of their own accelerations ("deck coupling absent"), so the balls run on a rigid
    race spinning at the spindle speed; the rotor keeps its inertia (a 1e9 J_z would turn the
    deck by the motor's reaction torque).
    """
    base = dict(n=n, m=m, eps=0.0, D=0.0, M_P=HEAVY, J_Px=HEAVY, J_Py=HEAVY, J_Pz=HEAVY,
                r_ball=steel_ball_radius(m), contact_E=STEEL_E, contact_nu=STEEL_NU)
    base.update(changes)
    return DriveParams(**base)

"""Beyond the paper (issue 12): material presets for balls with size, contact and rolling.

The terms themselves live in :mod:`abb_ros.model.kernels` (``add_ball_rotation``,
``contact_forces``, ``accel_rolling``, ``contact_substeps``) and are switched on by the
DriveParams fields ``r_ball``, ``contact_E``, ``contact_nu``, ``contact_damping``,
``rolling_mu``, ``rolling_stick_rate`` and ``ball_rotation`` (all zero: the paper's model).
docs/beyond_the_paper.md states the laws, the assumptions and the measurements.
"""

from __future__ import annotations

import math

from abb_ros.model.params import DriveParams

__all__ = ['STEEL_DENSITY', 'STEEL_E', 'STEEL_NU', 'steel_ball_radius', 'with_steel_balls']

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
    """``params`` with solid steel balls of its mass m: radius from the density, Hertzian
    contact (if ``contact``), rolling resistance ``rolling_mu`` [m], rolling-ball spin
    inertia (if ``rotation``)."""
    return params.replace(r_ball=steel_ball_radius(params.m),
                          contact_E=STEEL_E if contact else 0.0, contact_nu=STEEL_NU,
                          contact_damping=contact_damping, rolling_mu=rolling_mu,
                          ball_rotation=int(rotation))

"""Two-plane balancing: what one race leaves, and the two races that cancel it, in closed form.

Each race p (at height z_p, n_p balls of mass m_p at pitch radius R_p) acts on the deck through
its resultant B_p = m_p R_p sum_i exp(i phi_{p,i}) (complex, in the rotor's frame, angles from
G's direction). The rotor's imbalance is the force U_s = M eps along G and its moment about the
washers' plane U_c = M eps z_G - (J_z - J_x) sin tau cos tau exp(i psi_tau), the second term the
couple of its leaning principal axis (docs/equations.md, F4, F6: the rows of a leaning axis at
rest are those of a point couple of that resultant). The deck stays at rest where the balls
cancel both:

    B_1 + B_2 = -U_s,            z_1 B_1 + z_2 B_2 = -U_c,

so for z_1 != z_2

    B_1 = -(z_2 U_s - U_c) / (z_2 - z_1),      B_2 = -(U_c - z_1 U_s) / (z_2 - z_1).

A race holds at most its capacity |B_p| <= C_p m_p R_p (C_p = n_p for point balls, Eq. 26's
limit). One race (B_1 = -U_s, Eq. 26) cancels the force but leaves the couple
U_c - z_1 U_s (M eps (z_G - z_1) for an upright axis), which tilts the deck
(:func:`abb_ros.model.stability.coupled.residual_tilt`). The second race that removes it with
the least asked of either race is the mirror of race 1 about G, z_2 = 2 z_G - z_1: each race
then carries half the imbalance (:func:`mirror_race`). Each race's balls sit as a symmetric fan
about the direction of its B_p (:func:`abb_ros.model.stability.equilibrium.fan_phi_star`).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numpy as np

from abb_ros.model.dynamics.state import wrap_angle
from abb_ros.model.parameters.params import DriveParams, ParamError
from abb_ros.model.stability.equilibrium import fan_phi_star

__all__ = ['Race', 'TwoPlaneBalance', 'residual_couple', 'couple_left', 'imbalance_couple',
           'second_race',
           'two_plane_balance', 'mirror_race', 'race_angles', 'MIRROR_FALLBACK']


@dataclass(frozen=True)
class Race:
    """One race: ``n`` balls of mass ``m`` [kg] at pitch radius ``R`` [m], at height ``z`` [m]."""

    n: int
    m: float
    R: float
    z: float

    @property
    def capacity(self) -> float:
        """Largest resultant |B| = n m R [kg m] its balls can give (all together)."""
        return self.n * self.m * self.R


@dataclass(frozen=True)
class TwoPlaneBalance:
    """The two races' resultants ``B`` [kg m] (complex) and ball angles ``phi`` [rad] each."""

    races: tuple
    B: tuple
    phi: tuple


def _lean_couple(params: DriveParams) -> complex:
    """Return the leaning axis' part of U_c, -(J_z - J_x) sin tau cos tau exp(i psi_tau)."""
    lean = (params.J_z - params.J_x) * math.sin(params.tau) * math.cos(params.tau)
    return -lean * cmath.exp(1j * params.psi_tau)


def imbalance_couple(params: DriveParams) -> complex:
    """Return U_c [kg m^2]: the moment of the imbalance about the washers' plane (complex)."""
    return params.M * params.eps * params.z_G + _lean_couple(params)


def residual_couple(params: DriveParams) -> complex:
    """Return the couple race 1 alone leaves, U_c - z_B M eps [kg m^2].

    Exactly 0 where the race lies in G's plane and the axis is upright (the lever z_G - z_B is
    formed first, so no rounding leaves a couple that is not there).
    """
    return params.M * params.eps * (params.z_G - params.z_B) + _lean_couple(params)


def couple_left(params: DriveParams) -> complex:
    """Return the couple the drive's balls leave at their balance [kg m^2].

    :func:`residual_couple` for one race; 0 with a second race (its balance cancels the
    couple too, :func:`drive_balance`).
    """
    return 0j if params.race2_n else residual_couple(params)


def second_race(params: DriveParams) -> dict:
    """Return the second race that removes the couple one race leaves, for people to read.

    {} where one race cancels it; else the mirrored race (:func:`mirror_race`): its height
    ``z_m``, ball count ``n``, resultant ``B_kg_m`` and ball angles ``phi_deg`` beside race 1's
    ``race1_phi_deg``, or ``why`` (the ParamError text) where its balls cannot carry it.
    {} too for a drive that has its second race (race2.n > 0).
    """
    if params.race2_n:
        return {}
    try:
        mirror = mirror_race(params)
    except ParamError as err:
        return {'why': str(err)}
    if mirror is None:
        return {}
    return {'z_m': mirror.races[1].z, 'n': mirror.races[1].n, 'B_kg_m': abs(mirror.B[1]),
            'phi_deg': [math.degrees(v) for v in mirror.phi[1]],
            'race1_phi_deg': [math.degrees(v) for v in mirror.phi[0]]}


def race_angles(race: Race, B: complex, name: str) -> np.ndarray:
    """Return the ball angles [rad] of ``race`` giving the resultant B: a fan about arg B.

    ParamError naming ``name`` where |B| exceeds the race's capacity, or where one ball
    cannot give it (n = 1 needs |B| = m R exactly).
    """
    size = abs(B)
    if size > race.capacity * (1 + 1e-12):
        raise ParamError(name, race.n, f'a race whose capacity n m R >= {size:.4g} kg m',
                         f'this plane needs |B| = {size:.4g} kg m, its {race.n} balls hold '
                         f'{race.capacity:.4g}')
    if race.n == 1:
        if not math.isclose(size, race.capacity, rel_tol=1e-9):
            raise ParamError(name, race.n, 'at least 2 balls',
                             f'one ball gives |B| = m R only, the plane needs {size:.4g} kg m')
        return np.array([cmath.phase(B)])
    ratio = min(size / (race.m * race.R), float(race.n))
    return wrap_angle(fan_phi_star(race.n, ratio) + cmath.phase(B) - math.pi)


def two_plane_balance(params: DriveParams, second: Race) -> TwoPlaneBalance:
    """Return the balanced equilibrium of race 1 (the drive's) and ``second`` (closed form).

    ParamError naming ``race2.z`` where the races share a plane, ``race2.n`` or ``n`` where a
    plane's capacity is exceeded.
    """
    first = race1_of(params)
    dz = second.z - first.z
    if dz == 0.0:
        raise ParamError('race2.z', second.z, f'a height other than race 1\'s z_B = {first.z:g} m',
                         'two races in one plane cannot cancel a couple')
    U_s = params.M * params.eps
    U_c = imbalance_couple(params)
    B1 = complex(-(second.z * U_s - U_c) / dz)
    B2 = complex(-(U_c - first.z * U_s) / dz)
    phi = (race_angles(first, B1, 'n'), race_angles(second, B2, 'race2.n'))
    return TwoPlaneBalance((first, second), (B1, B2), phi)


def race1_of(params: DriveParams, z: float | None = None) -> Race:
    """Return race 1 of the drive (n balls of m at R), at z_B or at the height ``z``."""
    return Race(params.n, params.m, params.R, params.z_B if z is None else z)


def race2_of(params: DriveParams) -> Race:
    """Return the drive's own second race (race2.n balls; m, R and z as resolved, F7)."""
    return Race(params.race2_n, params.race2_mass, params.race2_radius, params.race2_z)


def drive_balance(params: DriveParams) -> TwoPlaneBalance:
    """Return the balanced equilibrium of a drive with two races (race2.n > 0), closed form."""
    if not params.race2_n:
        raise ParamError('race2.n', params.race2_n, 'at least 1 for the two-plane balance')
    second = race2_of(params)
    if second.z == params.z_B and residual_couple(params) == 0.0:
        return _one_plane_balance(params, second)
    return two_plane_balance(params, second)


def _one_plane_balance(params: DriveParams, second: Race) -> TwoPlaneBalance:
    """Return a balance of two races in one plane that holds G: the force shared by capacity.

    Such races balance any split of -U_s between them (a family); this member gives each race
    the share of its capacity, so both fans are alike.
    """
    first = race1_of(params)
    U_s = params.M * params.eps
    share = first.capacity / (first.capacity + second.capacity)
    B1, B2 = complex(-U_s * share), complex(-U_s * (1.0 - share))
    phi = (race_angles(first, B1, 'n'), race_angles(second, B2, 'race2.n'))
    return TwoPlaneBalance((first, second), (B1, B2), phi)


def balance_residual(params: DriveParams, phi) -> float:
    """Return the imbalance the balls at ``phi`` (race 1's, then race 2's) leave uncancelled.

    The larger of the force |B_1 + B_2 + U_s| / (m R) and, with two races, the couple
    |z_B B_1 + z_2 B_2 + U_c| / (m R |z_2 - z_B|): in units of one ball of race 1, like
    Eq. (26)'s residual (one race: the modulus of the force whose components
    :func:`~.equilibrium.eq26_residual` bounds).
    """
    phi = np.asarray(phi, dtype=float)
    unit = params.m * params.R
    e = np.exp(1j * phi)
    B1 = unit * complex(e[:params.n].sum())
    U_s = params.M * params.eps
    if not params.race2_n:
        return abs(B1 + U_s) / unit
    B2 = params.race2_mass * params.race2_radius * complex(e[params.n:].sum())
    lever = abs(params.race2_z - params.z_B) or 1.0
    couple = params.z_B * B1 + params.race2_z * B2 + imbalance_couple(params)
    return max(abs(B1 + B2 + U_s) / unit, abs(couple) / (unit * lever))


def balance_jacobian(params: DriveParams, phi) -> np.ndarray:
    """Return d(force, couple)/d phi of the two-plane conditions at ``phi``, shape (4, n).

    Rows Re, Im of sum_p B_p / (m R) and of sum_p z_p B_p / (m R |z_2 - z_B|); its null
    space is the tangent of the family of balanced states through phi (none where the races
    hold two balls each and a resultant: then the equilibrium is isolated).
    """
    phi = np.asarray(phi, dtype=float)
    weight = np.array([m * R for m, R, _ in params.per_ball()]) / (params.m * params.R)
    height = np.array([z for _, _, z in params.per_ball()])
    lever = abs(params.race2_z - params.z_B) or 1.0
    d = 1j * weight * np.exp(1j * phi)
    return np.stack([d.real, d.imag, (height * d).real / lever, (height * d).imag / lever])


def mirror_race(params: DriveParams) -> TwoPlaneBalance | None:
    """Return the two-plane balance with race 1's balls mirrored about G (z_2 = 2 z_G - z_B).

    None where one race already cancels the couple. Each race then carries half the imbalance,
    M eps / 2, for an upright axis; with a leaning axis the races share its couple as well
    (and where G lies in race 1's plane, the second race sits 10 mm away instead).
    """
    if residual_couple(params) == 0.0:
        return None
    z2 = 2.0 * params.z_G - params.z_B
    if z2 == params.z_B:
        z2 = params.z_B + MIRROR_FALLBACK
    return two_plane_balance(params, race1_of(params, z2))


MIRROR_FALLBACK = 0.01
"""Height above race 1 [m] of the suggested second race where G lies in race 1's plane."""

"""Predicted stability against spindle speed: |lambda|max table, unbalanced bands, verdict.

For fixed drive parameters the largest |Floquet multiplier| of the balanced equilibrium
(Section 4, Eqs. 35 and 37) is a function of the spindle speed alone. :func:`speed_table`
computes it once over the drive's speed range (in-plane and out-of-plane, with
:func:`abb_ros.model.stability.floquet.sweep_speed`), :func:`unbalanced_bands` finds the speed
intervals where it is >= 1, and :func:`assess` turns the value at the current speed into a verdict
a person reads (the analysis node publishes it on ``/diagnostics``).

Verdict rule (levels as diagnostic_msgs/DiagnosticStatus):

* ERROR: no balanced equilibrium (Eq. 26 unsolvable: the imbalance exceeds the balls'
  capacity, n m R < M eps), or |lambda|max >= 1 in either plane (below the translational
  natural frequency, or inside an unbalanced band), or the speed is not a finite number >= 0.
* WARN: balanced and stable, but the margin 1 - |lambda|max is below :data:`MARGIN_WARN`, or
  an unbalanced band starts within :data:`BAND_GUARD_WBAR` (in wbar, i.e. that fraction of
  omega0) of the current speed.
* OK: balanced and stable with room on both counts.

The margin is per period of the linearised system, so it is small at any speed (0.03 at the
paper's P3); the guard distance to a band is the more telling warning.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from abb_ros.model.parameters.params import DriveParams, ParamError
from abb_ros.model.stability import coupled, two_plane
from abb_ros.model.stability.equilibrium import balanced_equilibrium
from abb_ros.model.stability.floquet import point_stability, sweep_speed

__all__ = ['OK', 'WARN', 'ERROR', 'STALE', 'TABLE_POINTS', 'MARGIN_WARN', 'BAND_GUARD_WBAR',
           'TRANSLATIONAL', 'ROTATIONAL', 'Band', 'SpeedTable', 'Assessment', 'speed_table',
           'unbalanced_bands', 'assess', 'refine', 'rpm', 'NEAR_BALANCE', 'MEMBER_NEAR_BALLS',
           'member_near_balls']

OK, WARN, ERROR, STALE = 0, 1, 2, 3
"""Verdict levels, the byte values of diagnostic_msgs/DiagnosticStatus."""

TABLE_POINTS = 300
"""Speeds in the table. Over 0..1500 rad/s (5 rad/s apart) linear interpolation is within
1e-6 of the exact |lambda|max away from the bands and within 0.01 at their sharp peaks."""

MARGIN_WARN = 0.005
"""Margin 1 - |lambda|max below which a stable point is reported as WARN."""

BAND_GUARD_WBAR = 0.1
"""A stable point closer than this (dimensionless speed wbar) to an unbalanced band is WARN."""

TRANSLATIONAL = ('X', 'Y', 'Z')
ROTATIONAL = ('gamma', 'alpha', 'beta')


def rpm(omega: float) -> float:
    """Convert the spindle speed omega [rad/s] to revolutions per minute (edge unit)."""
    return omega * 30.0 / math.pi


@dataclass(frozen=True)
class Band:
    """An interval of spindle speed [rad/s] where the balanced equilibrium is unstable.

    ``near`` names the natural frequency (linear.natural_frequencies) nearest the band: a
    coordinate in TRANSLATIONAL or ROTATIONAL.
    """

    lo: float
    hi: float
    near: str
    near_omega: float

    @property
    def kind(self) -> str:
        """'translational' or 'rotational', after the natural frequency nearest the band."""
        return 'translational' if self.near in TRANSLATIONAL else 'rotational'

    def contains(self, omega: float) -> bool:
        """Return whether omega [rad/s] lies in the band (edges included)."""
        return self.lo <= omega <= self.hi

    def distance(self, omega: float) -> float:
        """Return the speed distance [rad/s] from omega to the band (0 inside)."""
        return max(self.lo - omega, omega - self.hi, 0.0)


@dataclass(frozen=True)
class SpeedTable:
    """|lambda|max against speed for one set of parameters (arrays shape (K,), omegas rad/s).

    ``lam_in``/``lam_out`` are +inf everywhere when no balanced equilibrium exists
    (``exists`` False, ``reason`` says why). ``compute_s`` is the wall time it took;
    ``neutral`` the family's neutral in-plane multipliers removed (floquet_batch.py).
    ``coupled``: a drive with heights (docs/equations.md F4), whose one lam_max over the
    spindle period (:mod:`abb_ros.model.stability.coupled`) both ``lam_in`` and ``lam_out``
    hold.
    """

    params: DriveParams
    omega_max: float
    omegas: np.ndarray
    lam_in: np.ndarray
    lam_out: np.ndarray
    exists: bool
    phi_star: np.ndarray
    reason: str
    natural: dict
    bands: tuple
    compute_s: float = 0.0
    neutral: int = 0
    coupled: bool = False

    def at(self, omega: float) -> tuple[float, float]:
        """Return (lam_in, lam_out) at omega [rad/s], interpolated (clamped to the table)."""
        return (float(np.interp(omega, self.omegas, self.lam_in)),
                float(np.interp(omega, self.omegas, self.lam_out)))


def speed_table(params: DriveParams, omega_max: float, points: int = TABLE_POINTS
                ) -> SpeedTable:
    """Compute the table over omega_max / points .. omega_max [rad/s] (Floquet needs omega > 0).

    Raises ParamError for a speed range or point count that cannot make a table.
    """
    if not (math.isfinite(omega_max) and omega_max > 0):
        raise ParamError('max_spindle_speed', omega_max, '(0, inf) rad/s')
    if points < 2:
        raise ParamError('table_points', points, '[2, inf)')
    start = time.perf_counter()
    eq = balanced_equilibrium(params)
    omegas = np.linspace(omega_max / points, omega_max, points)
    natural = coupled.deck_natural_frequencies(params)
    if eq.exists and params.off_plane:
        lam_in = lam_out = coupled.lam_max_sweep(params, omegas, eq.phi_star)
        bands = unbalanced_bands(omegas, lam_in, natural)
    elif eq.exists:
        lam_in = sweep_speed(params, omegas, 'in', eq.phi_star)
        lam_out = sweep_speed(params, omegas, 'out', eq.phi_star)
        bands = unbalanced_bands(omegas, np.maximum(lam_in, lam_out), natural)
    else:
        lam_in = lam_out = np.full(points, math.inf)
        bands = ()
    neutral = int(coupled.family_frame(params, eq.phi_star)[1]) \
        if eq.exists and params.n_balls > 1 else 0
    return SpeedTable(params, float(omega_max), omegas, lam_in, lam_out, eq.exists,
                      eq.phi_star, eq.reason, natural, bands, time.perf_counter() - start,
                      neutral, params.off_plane)


def unbalanced_bands(omegas, lam, natural: dict) -> tuple:
    """Return the intervals of omegas [rad/s] where lam >= 1.

    The edges are found by linear interpolation of lam - 1; a band that starts at the first table
    point extends down to 0 (the spindle at rest). ``natural`` : {coordinate: natural frequency
    [rad/s]} names each band.
    """
    omegas = np.asarray(omegas, dtype=float)
    unstable = np.asarray(lam) >= 1.0
    bands = []
    k, K = 0, omegas.size
    while k < K:
        if not unstable[k]:
            k += 1
            continue
        j = k
        while j + 1 < K and unstable[j + 1]:
            j += 1
        lo = 0.0 if k == 0 else _crossing(omegas, lam, k - 1, k)
        hi = omegas[-1] if j == K - 1 else _crossing(omegas, lam, j, j + 1)
        bands.append(_named_band(lo, hi, natural))
        k = j + 1
    return tuple(bands)


def _crossing(omegas, lam, i, j) -> float:
    """Return the speed where lam crosses 1 between table points i and j (linear)."""
    a, b = lam[i] - 1.0, lam[j] - 1.0
    if not (math.isfinite(a) and math.isfinite(b)) or a == b:
        return float(omegas[j])
    return float(omegas[i] + (omegas[j] - omegas[i]) * a / (a - b))


def _named_band(lo, hi, natural) -> Band:
    name = min(natural, key=lambda n: max(lo - natural[n], natural[n] - hi, 0.0)
               + 1e-9 * abs(natural[n] - 0.5 * (lo + hi)))
    return Band(float(lo), float(hi), name, float(natural[name]))


@dataclass(frozen=True)
class Assessment:
    """The analysis' verdict at one speed.

    ``level`` (OK/WARN/ERROR), ``message``, ``margin`` (1 - max |lambda|, -inf without a
    balanced equilibrium) and ``values`` (key -> value).
    """

    level: int
    message: str
    margin: float
    values: dict = field(default_factory=dict)


def assess(table: SpeedTable, omega: float, exact=None) -> Assessment:
    """Assess the spindle speed omega [rad/s] from the table.

    ``exact`` : optional :class:`abb_ros.model.stability.floquet.PointStability` computed at
    (nearly) this speed; its multipliers replace the interpolated ones.
    """
    p = table.params
    values = _base_values(table, omega)
    if not (isinstance(omega, (int, float)) and math.isfinite(omega) and omega >= 0):
        return Assessment(ERROR, f'spindle speed {omega!r} is not a finite number >= 0',
                          -math.inf, values)
    if not table.exists:
        return Assessment(ERROR, table.reason + '; no balanced equilibrium', -math.inf, values)
    tilt = ''
    if exact is not None:
        lam_in, lam_out, source = exact.lam_in, exact.lam_out, f'exact at {exact.omega:.2f} rad/s'
        values.update(family_member=exact.member, neutral_modes_removed=exact.neutral,
                      family_invariance=exact.invariance,
                      phi_star_deg=', '.join(f'{math.degrees(x):.2f}' for x in exact.phi_star))
        tilt = _tilt_text(p, exact.residual_tilt, values)
    else:
        lam_in, lam_out = table.at(omega)
        source = 'table (interpolated)'
    lam = max(lam_in, lam_out)
    margin = 1.0 - lam
    values.update(lambda_in=lam_in, lambda_out=lam_out, margin=margin, source=source,
                  lambda_max=lam if table.coupled else max(lam_in, lam_out ** 2))
    wbar = p.wbar(omega)
    group = 'coupled' if table.coupled else 'in-plane' if lam_in >= lam_out else 'out-of-plane'
    lam_text = f'|lambda|max {lam:.4f} ({group})'
    if lam >= 1.0 or omega < table.omegas[0] and omega < p.omega0:
        if omega < p.omega0:
            return Assessment(ERROR, f'unbalanced: below translational natural frequency '
                              f'(wbar {wbar:.2f} < 1, omega0 {p.omega0:.1f} rad/s); the balls '
                              f'cannot balance, {lam_text}', margin, values)
        band = _band_at(table, omega)
        where = (f'near the {band.kind} natural frequency ({band.near}, wbar ~ '
                 f'{p.wbar(band.near_omega):.2f})' if band else 'between table points')
        span = (f'; band wbar {p.wbar(band.lo):.2f}-{p.wbar(band.hi):.2f} '
                f'({band.lo:.0f}-{band.hi:.0f} rad/s)' if band else '')
        return Assessment(ERROR, f'unbalanced: inside an unbalanced band {where} at wbar '
                          f'{wbar:.2f}{span}; {lam_text}', margin, values)
    near = min(table.bands, key=lambda b: b.distance(omega), default=None)
    text = f'balanced and stable, margin {margin:.3f} at wbar {wbar:.2f}{tilt}'
    if near is not None and p.wbar(near.distance(omega)) < BAND_GUARD_WBAR:
        edge = near.lo if near.lo > omega else near.hi
        return Assessment(WARN, f'{text}, but an unbalanced band near the {near.kind} natural '
                          f'frequency ({near.near}) is {near.distance(omega):.0f} rad/s away '
                          f'(edge wbar {p.wbar(edge):.2f})', margin, values)
    if margin < MARGIN_WARN:
        return Assessment(WARN, f'{text}: small margin (below {MARGIN_WARN:g}), '
                          f'{lam_text}', margin, values)
    return Assessment(OK, text, margin, values)


def _tilt_text(p: DriveParams, tilt: float, values: dict) -> str:
    """Put the predicted residual tilt in ``values``; return its clause for the message."""
    if not math.isfinite(tilt):
        return ''
    values['residual_tilt_rad'] = tilt
    if two_plane.couple_left(p) == 0.0:     # the balls cancel it all (tilt at round-off)
        return ''
    text = f'; residual tilt {tilt * 1e3:.3g} mrad (one race cannot cancel the couple)'
    if 'second_race_z_m' in values:
        text += (f', a second race at z = {values["second_race_z_m"] * 1e3:.3g} mm with '
                 f'|B_2| = {values["second_race_B_kg_m"]:.3g} kg m would remove it')
    return text


def _two_plane_values(p: DriveParams, values: dict) -> None:
    """Add the couple one race leaves and the mirrored second race that removes it."""
    values['residual_couple_kg_m2'] = abs(two_plane.couple_left(p))
    race = two_plane.second_race(p)
    if 'why' in race:
        values['second_race'] = race['why']
    elif race:
        values['second_race_z_m'] = race['z_m']
        values['second_race_B_kg_m'] = race['B_kg_m']
        values['second_race_phi_deg'] = ', '.join(f'{x:.2f}' for x in race['phi_deg'])


def _band_at(table: SpeedTable, omega: float):
    inside = [b for b in table.bands if b.contains(omega)]
    if inside:
        return inside[0]
    return min(table.bands, key=lambda b: b.distance(omega), default=None)


def _base_values(table: SpeedTable, omega) -> dict:
    p = table.params
    ok = isinstance(omega, (int, float)) and math.isfinite(omega)
    values = {'omega': float(omega) if ok else omega,
              'rpm': rpm(omega) if ok else omega,
              'wbar': p.wbar(omega) if ok else omega,
              'lambda_in': math.inf, 'lambda_out': math.inf, 'margin': -math.inf,
              'balanced_equilibrium_exists': table.exists,
              'phi_star_deg': ', '.join(f'{math.degrees(x):.2f}' for x in table.phi_star),
              'family_member': 'symmetric fan',
              'neutral_modes_removed': table.neutral,
              'omega0': p.omega0}
    for name, w in table.natural.items():
        values[f'natural_frequency_{name}'] = w
    values['unbalanced_bands_rad_s'] = '; '.join(f'{b.lo:.1f}-{b.hi:.1f}' for b in table.bands)
    values['unbalanced_bands_rpm'] = '; '.join(f'{rpm(b.lo):.0f}-{rpm(b.hi):.0f}'
                                               for b in table.bands)
    values['unbalanced_bands_near'] = ', '.join(b.near for b in table.bands)
    values['speed_range_rad_s'] = f'0-{table.omega_max:g}'
    values['n'] = p.n
    values['eps'] = p.eps
    values['table_compute_s'] = table.compute_s
    values['source'] = 'table (interpolated)'
    if p.off_plane:
        _two_plane_values(p, values)
    return values


def refine(table: SpeedTable, omega: float, member=None):
    """Compute the exact multipliers at omega [rad/s] (about 2 ms).

    None when the table has no balanced equilibrium or omega <= 0.

    ``member`` : a member of the balanced family [rad] (:func:`member_near_balls`), default
    the table's symmetric fan.
    """
    if not table.exists or not (math.isfinite(omega) and omega > 0):
        return None
    if member is None:
        return point_stability(table.params, omega, table.phi_star)
    return point_stability(table.params, omega, member, member=MEMBER_NEAR_BALLS)


NEAR_BALANCE = 0.05
"""The balls are near balance when the residual of Eq. (26) at their angles is below this
(in units of one ball's m R: they cancel the imbalance to within 5 % of one ball)."""

MEMBER_NEAR_BALLS = 'nearest the balls'
"""``PointStability.member`` of the member projected from the balls' present angles."""


def member_near_balls(params: DriveParams, phi):
    """Return the member of the balanced family nearest the balls' present angles phi [rad].

    Only once they are near balance (:data:`NEAR_BALANCE`); None until then, or for fewer than
    3 balls (n = 2 with eps > 0 has one member up to the balls' order: the fan).
    """
    if params.n < 3 or len(phi) != params.n:   # before the imports: the analysis asks at 50 Hz
        return None
    from abb_ros.model.stability.equilibrium import balls_apart, eq26_residual
    from abb_ros.model.stability.family import nearest_member
    phi = np.asarray(phi, dtype=float)
    if phi.size != params.n or not np.all(np.isfinite(phi)):
        return None
    if eq26_residual(params, phi) > NEAR_BALANCE:
        return None
    member, _ = nearest_member(params.M * params.eps / (params.m * params.R), phi)
    if member is None or not balls_apart(params, member):
        return None
    return member

"""Physical parameters of the drive (Table 1 of Kim, Lee & Chung 2005) and Eq. (39).

All values are SI (m, kg, s, rad). ``DriveParams`` is immutable and validated on
construction; an invalid value raises :class:`ParamError`, which names the parameter
and its valid range.

Dimensionless parameters, Eq. (39)::

    wbar = omega / omega0      zeta = 2 c / (omega0 (M + M_P))      Dbar = D / (m R^2 omega0)
    epsbar = eps / R           mbar = m / M

with omega0 the translational natural frequency for m = omega = 0 (Section 4): the Y
equation (28) then reads (M + M_P) Y'' + 4 k Y = 0, so omega0 = sqrt(4 k / (M + M_P)).
It is computed from the parameters, never typed in.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

from abb_ros.model.parameters.drive_spec import (
    DRIVE_SPECS,
    MAX_BALLS,
    METAL_C,
    OFF_PLANE,
    RUBBER_C,
    SPEED_SPEC,
)
from abb_ros.model.parameters.param_spec import ParamError, ParamSpec

__all__ = [
    'ParamError', 'DriveParams', 'PARAM_SPECS', 'DIMENSIONLESS_NAMES', 'METAL_C', 'RUBBER_C',
    'apply_settings', 'parse_value', 'MAX_BALLS', 'zero_text',
]

PARAM_SPECS: dict[str, ParamSpec] = {s.short: s for s in DRIVE_SPECS}
"""{SI name: spec} of the drive parameters (abb_ros/model/parameters/drive_spec.py)."""

FIELD_OF = {name: name.replace('.', '_') for name in PARAM_SPECS}
"""{SI name: DriveParams field}: the same, with the dots of ``race2.n`` ... as underscores."""
NAME_OF = {field: name for name, field in FIELD_OF.items()}
"""{DriveParams field: SI name}, the inverse of :data:`FIELD_OF`."""


def _default(name):
    return PARAM_SPECS[name].default


def zero_text(name: str) -> str:
    """Return '0' with the unit of parameter ``name`` ('0 m', '0' for a count), for messages."""
    unit = PARAM_SPECS[name].unit
    return f'0 {unit}' if unit else '0'


DIMENSIONLESS_NAMES = ('mbar', 'epsbar', 'zeta', 'Dbar', 'wbar')
"""Eq. (39) names accepted by :func:`apply_settings`, applied in this order."""


@dataclass(frozen=True)
class DriveParams:
    """Physical parameters of the optical disk drive with ABB. All values are SI.

    Defaults are Table 1 of the paper with rubber washers, eps = 0.25 mm and n = 2.
    """

    a: float = _default('a')
    b: float = _default('b')
    d: float = _default('d')
    R: float = _default('R')
    M_P: float = _default('M_P')
    M: float = _default('M')
    m: float = _default('m')
    J_Px: float = _default('J_Px')
    J_Py: float = _default('J_Py')
    J_Pz: float = _default('J_Pz')
    J_x: float = _default('J_x')
    J_y: float = _default('J_y')
    J_z: float = _default('J_z')
    k: float = _default('k')
    c: float = _default('c')
    D: float = _default('D')
    eps: float = _default('eps')
    n: int = _default('n')
    # ---- ball size, contact, rolling (docs/ball_size_contact_rolling.md); zero = the paper ----
    r_ball: float = _default('r_ball')
    contact_E: float = _default('contact_E')
    contact_nu: float = _default('contact_nu')
    contact_damping: float = _default('contact_damping')
    rolling_mu: float = _default('rolling_mu')
    rolling_stick_rate: float = _default('rolling_stick_rate')
    ball_rotation: int = _default('ball_rotation')
    # ---- mass centres off the plane, leaning rotor axis (equations.md F4, F6); 0 = paper ----
    z_P: float = _default('z_P')
    z_G: float = _default('z_G')
    z_B: float = _default('z_B')
    tau: float = _default('tau')
    psi_tau: float = _default('psi_tau')
    # ---- a second race (two-plane balancing, equations.md F7); race2.n 0 = none ----
    race2_n: int = _default('race2.n')
    race2_m: float = _default('race2.m')
    race2_R: float = _default('race2.R')
    race2_D: float = _default('race2.D')
    race2_z: float = _default('race2.z')

    def __post_init__(self):
        for f in dataclasses.fields(self):
            PARAM_SPECS[NAME_OF[f.name]].check(getattr(self, f.name), NAME_OF[f.name])
        if abs(self.J_x - self.J_y) > 1e-9 * max(self.J_x, self.J_y):
            raise ParamError('J_y', self.J_y, f'equal to J_x = {self.J_x:g} kg m^2',
                             'the equations of motion (Eqs. 21, 22) hold for an axisymmetric '
                             'rotor only')
        for field in ('n', 'race2_n'):
            count = getattr(self, field)
            if isinstance(count, float):
                if not count.is_integer():
                    raise ParamError(NAME_OF[field], count,
                                     PARAM_SPECS[NAME_OF[field]].valid_text(), 'not an integer')
                object.__setattr__(self, field, int(count))
        if self.n_balls > MAX_BALLS:
            raise ParamError('race2.n', self.race2_n, f'at most {MAX_BALLS - self.n} (n + '
                             f'race2.n <= {MAX_BALLS})', 'more balls than the model takes')
        self._check_beyond_paper()
        self._check_heights()
        self._check_race2()

    def _check_race2(self):
        """Refuse a second race's m or R that is neither 0 (race 1's) nor within race 1's range.

        race2.m and race2.R take 0 for race 1's value, so their specs start at 0; a value
        between would make the race's m R^2 vanish and the step non-finite.
        """
        for name, own in (('race2.m', 'm'), ('race2.R', 'R')):
            value, spec = self.value(name), PARAM_SPECS[own]
            if value != 0.0 and value < spec.low:
                raise ParamError(name, value, f"0 (race 1's {own}) or [{spec.low:g}, "
                                 f'{spec.high:g}] {spec.unit}', f'as {own} itself')

    def _check_heights(self):
        """Refuse heights or a leaning axis beside the ball terms that assume the plane."""
        if not self.off_plane:
            return
        for name in ('contact_E', 'rolling_mu', 'ball_rotation'):
            if getattr(self, name):
                height = self.off_plane_name
                raise ParamError(height, self.value(height),
                                 f'{zero_text(height)} while {name} > 0',
                                 'mass centres off the deck plane, a leaning rotor axis and a '
                                 'second race combine with point balls only (contact_E, '
                                 'rolling_mu and ball_rotation 0)')

    @property
    def off_plane(self) -> bool:
        """Whether the drive leaves the paper's plane model (:data:`OFF_PLANE`).

        P, G or a race off the washers' plane, a leaning rotor axis, or a second race.
        """
        return any(self.value(h) != 0.0 for h in OFF_PLANE)

    @property
    def off_plane_name(self) -> str:
        """The first nonzero of :data:`OFF_PLANE` ('' in the paper's plane), for messages."""
        return next((h for h in OFF_PLANE if self.value(h) != 0.0), '')

    def value(self, name: str):
        """Return the value of SI parameter ``name`` (``race2.n`` as well as ``k``)."""
        return getattr(self, FIELD_OF[name])

    # ---- the second race (F7): its values, race 1's where given as 0 ----
    @property
    def n_balls(self) -> int:
        """Balls of both races: race 1's n, then race 2's race2.n (the state's ball count)."""
        return self.n + self.race2_n

    @property
    def race2_mass(self) -> float:
        """Mass of one ball of race 2 [kg] (race 1's m where race2.m is 0)."""
        return self.race2_m or self.m

    @property
    def race2_radius(self) -> float:
        """Pitch radius of race 2 [m] (race 1's R where race2.R is 0)."""
        return self.race2_R or self.R

    @property
    def race2_drag(self) -> float:
        """Drag of one ball of race 2 [kg m^2/s] (race 1's D where race2.D is 0)."""
        return self.race2_D or self.D

    def per_ball(self) -> list[tuple[float, float, float]]:
        """Return each ball's (m_i, R_i, z_i), race 1's balls then race 2's."""
        return ([(self.m, self.R, self.z_B)] * self.n
                + [(self.race2_mass, self.race2_radius, self.race2_z)] * self.race2_n)

    def _check_beyond_paper(self):
        """Check the terms beyond the paper: what needs a ball size, and whether balls fit."""
        if float(self.ball_rotation) not in (0.0, 1.0):
            raise ParamError('ball_rotation', self.ball_rotation, '0 or 1')
        object.__setattr__(self, 'ball_rotation', int(self.ball_rotation))
        for name in ('contact_E', 'rolling_mu'):
            if getattr(self, name) > 0 and self.r_ball <= 0:
                raise ParamError('r_ball', self.r_ball, '(0, R) m',
                                 f'{name} > 0 needs a ball radius')
        if self.r_ball >= self.R:
            raise ParamError('r_ball', self.r_ball, f'[0, R = {self.R:g}) m')
        if self.contact_E > 0 and self.n * 2.0 * math.asin(self.r_ball / self.R) > 2 * math.pi:
            raise ParamError('r_ball', self.r_ball,
                             f'at most R sin(pi/n) = {self.R * math.sin(math.pi / self.n):g} m',
                             f'{self.n} balls of this size do not fit on the race')

    @property
    def beyond_paper(self) -> tuple[str, ...]:
        """Return the names of the active terms beyond the paper.

        Contact, rolling resistance, ball rotation: terms the paper's equations and its linear
        analysis do not have.
        """
        active = []
        if self.contact_E > 0:
            active.append('contact')
        if self.rolling_mu > 0:
            active.append('rolling_mu')
        if self.ball_rotation:
            active.append('ball_rotation')
        return tuple(active)

    @property
    def contact_separation(self) -> float:
        """Smallest angular separation of two touching balls, 2 asin(r_ball / R) [rad]."""
        return 2.0 * math.asin(self.r_ball / self.R)

    # ---- derived quantities -------------------------------------------------------------
    @property
    def omega0(self) -> float:
        """Translational natural frequency sqrt(4k/(M+M_P)) [rad/s] (Section 4, m = omega = 0)."""
        return math.sqrt(4.0 * self.k / (self.M + self.M_P))

    @property
    def zeta(self) -> float:
        """Damping factor 2c/(omega0 (M+M_P)), Eq. (39)."""
        return 2.0 * self.c / (self.omega0 * (self.M + self.M_P))

    @property
    def Dbar(self) -> float:
        """Dimensionless drag D/(m R^2 omega0), Eq. (39)."""
        return self.D / (self.m * self.R ** 2 * self.omega0)

    @property
    def epsbar(self) -> float:
        """Dimensionless eccentricity eps/R, Eq. (39)."""
        return self.eps / self.R

    @property
    def mbar(self) -> float:
        """Dimensionless ball mass m/M, Eq. (39)."""
        return self.m / self.M

    @property
    def can_balance(self) -> bool:
        """True when the balls can cancel the imbalance: n m R >= M eps (Eq. 26 solvable)."""
        return self.n * self.m * self.R >= self.M * self.eps

    def wbar(self, omega: float) -> float:
        """Dimensionless spindle speed omega/omega0, Eq. (39)."""
        return omega / self.omega0

    def dimensionless(self) -> dict[str, float]:
        """Return the Eq. (39) parameters that do not depend on the speed."""
        return {'zeta': self.zeta, 'Dbar': self.Dbar, 'epsbar': self.epsbar,
                'mbar': self.mbar, 'n': self.n}

    def replace(self, **changes) -> 'DriveParams':
        """Return a validated copy with ``changes`` applied (SI names)."""
        unknown = set(changes) - set(PARAM_SPECS)
        if unknown:
            name = sorted(unknown)[0]
            raise ParamError(name, changes[name], 'one of ' + ', '.join(PARAM_SPECS),
                             'unknown parameter')
        return dataclasses.replace(self, **{FIELD_OF[k]: v for k, v in changes.items()})

    def as_dict(self) -> dict[str, float]:
        """Return {SI name: value} of every field, in declaration order."""
        return {NAME_OF[k]: v for k, v in dataclasses.asdict(self).items()}

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], base: 'DriveParams | None' = None
                     ) -> 'DriveParams':
        """Parameters from a flat SI mapping (unknown keys are an error)."""
        for key in values:
            if not isinstance(key, str):
                raise ParamError(str(key), values[key], 'one of ' + ', '.join(PARAM_SPECS),
                                 'unknown parameter')
        return (base or cls()).replace(**dict(values))


def parse_value(name: str, text: str) -> float:
    """Parse the text of a ``--set name=value`` into a number, naming the parameter on error."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        spec = PARAM_SPECS.get(name)
        valid = spec.valid_text() if spec else 'a finite number'
        raise ParamError(name, text, valid, 'not a number') from None
    if name in ('n', 'race2.n'):
        if not value.is_integer():
            raise ParamError(name, text, PARAM_SPECS[name].valid_text(), 'not an integer')
        return int(value)
    return value


_DIMLESS_RANGES = {
    'wbar': '[0, inf)', 'zeta': '[0, inf)', 'Dbar': '[0, inf)', 'epsbar': '[0, inf)',
    'mbar': '(0, inf)',
}


def apply_settings(params: DriveParams, settings: Mapping[str, Any],
                   omega: float | None = None) -> tuple[DriveParams, float | None]:
    """Apply SI and Eq. (39) settings; return the new parameters and spindle speed.

    SI names (``k``, ``c``, ``eps``, ..., and ``omega`` for the spindle speed) are applied
    first, all at once; then the dimensionless ones in the order mbar, epsbar, zeta, Dbar,
    wbar, each converted with the parameters as they stand at that point (so ``mbar``
    changes m and leaves the SI drag D alone, while ``Dbar`` sets D for the final m).
    """
    si = {}
    dimless = {}
    for key, value in settings.items():
        if key in PARAM_SPECS:
            si[key] = value
        elif key == 'omega':
            omega = SPEED_SPEC.check(value)
        elif key in DIMENSIONLESS_NAMES:
            dimless[key] = value
        else:
            valid = ', '.join(list(PARAM_SPECS) + ['omega'] + list(DIMENSIONLESS_NAMES))
            raise ParamError(key, value, 'a known name: ' + valid, 'unknown parameter')
    if si:
        params = params.replace(**si)
    for key in DIMENSIONLESS_NAMES:
        if key in dimless:
            params, omega = _apply_dimensionless(params, omega, key, dimless[key])
    return params, omega


def _apply_dimensionless(params, omega, key, value):
    """Apply one Eq. (39) setting; an SI value out of range is refused naming ``key``."""
    try:
        if key == 'mbar':
            _checked_positive('mbar', value)
            params = params.replace(m=value * params.M)
        elif key == 'epsbar':
            params = params.replace(eps=_checked_nonneg('epsbar', value) * params.R)
        elif key == 'zeta':
            z = _checked_nonneg('zeta', value)
            params = params.replace(c=z * params.omega0 * (params.M + params.M_P) / 2.0)
        elif key == 'Dbar':
            Dbar = _checked_nonneg('Dbar', value)
            params = params.replace(D=Dbar * params.m * params.R ** 2 * params.omega0)
        else:
            omega = SPEED_SPEC.check(_checked_nonneg('wbar', value) * params.omega0)
    except ParamError as exc:
        if exc.name == key:
            raise
        raise ParamError(key, value, f'{exc.name} in {exc.valid}',
                         f'{exc.name} would be {_short(exc.value)}') from None
    return params, omega


def _short(value):
    return f'{value:.6g}' if isinstance(value, float) else repr(value)


def _checked_nonneg(name, value, unit=''):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or value < 0:
        raise ParamError(name, value, f'[0, inf) {unit}'.rstrip())
    return float(value)


def _checked_positive(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or value <= 0:
        raise ParamError(name, value, _DIMLESS_RANGES[name])
    return float(value)

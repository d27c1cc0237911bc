"""Balanced equilibrium of the balls, Eq. (26), and the balancing limits of Figs. 6 and 7.

At the balanced equilibrium (X* = Y* = Z* = alpha* = beta* = gamma* = 0) the balls cancel
the imbalance M eps of the rotor, Eq. (26)::

    M eps / (m R) + sum_i cos(phi_i*) = 0,        sum_i sin(phi_i*) = 0.

For n = 2 the solution is phi_1* = -phi_2* with cos(phi_1*) = -M eps / (2 m R). The paper's
printed closed form, Eq. (34), ``-atan(sqrt((2mR/(M eps))^2 - 1))``, has the right magnitude of
tan but the wrong quadrant: it gives |phi*| < 90 deg, where Eq. (26) needs cos(phi*) < 0, i.e. the
balls on the far side of the imbalance G (|phi*| = 106.1 deg at P3, mbar = 0.03). The corrected
form used here is phi_1* = -(pi - atan(sqrt((2mR/(M eps))^2 - 1))) = -acos(-M eps / (2 m R)).

For n > 2 the equilibria form a family. The documented choice here is the *symmetric fan*: the
balls evenly spaced by delta, centred on the side opposite G::

    phi_i* = pi - (i - (n + 1) / 2) delta,   i = 1..n   (wrapped to (-pi, pi]),

with delta in [0, 2 pi / n] solving sin(n delta / 2) / sin(delta / 2) = M eps / (m R) (the
Dirichlet kernel, monotone on that interval). For n = 2 this is exactly the corrected Eq. (34),
with the paper's sign convention phi_1* = -phi_2* < 0.
Any other configuration may be passed explicitly as ``phi_star`` and is checked against Eq. (26).

The fan is one member of a family: Eq. (26) is two conditions on n angles, so for n >= 3 its
solutions form a manifold of dimension n - 2, and for n = 2 at eps = 0 the rotations of the
opposite pair. The stability analysis removes the family's neutral directions
(:mod:`abb_ros.model.stability.family`, :mod:`abb_ros.model.stability.floquet`) and can evaluate
any member. No balanced equilibrium exists when the imbalance exceeds the balls' capacity C m R < M
eps (the balls cannot cancel it) or when n = 1 and m R != M eps; the result then says so
(``exists = False`` and a reason), never NaN. Point masses (the paper's model) have the
capacity C = n. Balls with a size that touch (``r_ball`` > 0 and ``contact_E`` > 0) cannot come
closer than the contact separation s = 2 asin(r_ball / R); the largest resultant n such balls
give is that of the packed chain, each next to the other at s (:func:`ball_capacity`)::

    C = sin(n s / 2) / sin(s / 2)      (< n; ten 0.156 g steel balls on R = 14.9 mm: 8.05).

The symmetric fan's spacing delta falls from 2 pi / n to s as the imbalance grows to C m R, so
the fan is a valid equilibrium (balls apart) exactly where one exists, and at the capacity it
is the packed chain. A given ``phi_star`` must keep its balls s apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from abb_ros.model.dynamics.state import wrap_angle
from abb_ros.model.parameters.params import DriveParams, ParamError
from abb_ros.model.stability.family import min_spacing

__all__ = ['BalancedEquilibrium', 'balanced_equilibrium', 'phi_star_two_balls', 'fan_phi_star',
           'eq26_residual', 'epsbar_lim', 'mbar_lim', 'EQ26_TOL', 'ball_capacity',
           'balls_touch', 'SPACING_TOL', 'no_equilibrium_reason', 'least_spacing',
           'balls_apart', 'balanced_phi_star']

EQ26_TOL = 1e-9
"""Largest |Eq. (26) residual| (dimensionless, relative to n) accepted for a given phi_star."""

SPACING_TOL = 1e-9
"""A given phi_star's balls may be this much [rad] closer than the contact separation (the
packed chain at the capacity, computed in floating point)."""


def balls_touch(params: DriveParams) -> bool:
    """Return whether the balls have a size and touch (contact on): their spacing is bounded."""
    return params.n > 1 and params.r_ball > 0.0 and params.contact_E > 0.0


def ball_capacity(params: DriveParams) -> float:
    """Return C, the largest |sum_i exp(i phi_i)| the balls can make (they cancel C m R).

    n for point masses or without contact; sin(n s / 2) / sin(s / 2) for balls that touch at
    the contact separation s = 2 asin(r_ball / R) (the packed chain, module docstring).
    """
    if not balls_touch(params):
        return float(params.n)
    half = 0.5 * params.contact_separation
    return math.sin(params.n * half) / math.sin(half)


@dataclass(frozen=True)
class BalancedEquilibrium:
    """Ball angles of the balanced equilibrium, Eq. (26).

    ``phi_star`` : ndarray, shape (n,) [rad], empty when ``exists`` is False.
    ``reason`` : why no balanced equilibrium exists ('' when it does).
    """

    exists: bool
    phi_star: np.ndarray
    reason: str = ''

    @property
    def phi_star_deg(self) -> list:
        """Ball angles phi_star in degrees."""
        return [math.degrees(p) for p in self.phi_star]


def eq26_residual(params: DriveParams, phi_star) -> float:
    """Return the largest |left-hand side| of the two Eq. (26) sums (dimensionless)."""
    phi = np.asarray(phi_star, dtype=float)
    ratio = params.M * params.eps / (params.m * params.R)
    return max(abs(ratio + np.cos(phi).sum()), abs(np.sin(phi).sum()))


def phi_star_two_balls(ratio: float) -> tuple[float, float]:
    """Solve Eq. (34) in the corrected quadrant, for n = 2 and ratio = M eps / (m R) <= 2.

    Returns (phi_1*, phi_2*) = (-(pi - atan(sqrt((2/ratio)^2 - 1))), +...) [rad]; for ratio = 0
    the balls sit opposite each other at -+90 deg.
    """
    if ratio > 2.0:
        raise ValueError('no balanced equilibrium: 2 m R < M eps')
    if ratio == 0.0:
        return -math.pi / 2, math.pi / 2
    phi = math.pi - math.atan(math.sqrt((2.0 / ratio) ** 2 - 1.0))
    return -phi, phi


def fan_phi_star(n: int, ratio):
    """Return the symmetric-fan solution of Eq. (26) for n >= 2 balls.

    ``ratio`` = M eps / (m R) <= n may be an array of shape (B,); the result then has shape (B, n)
    [rad]. Its spacing falls monotonically with ratio (module docstring), so balls that touch are
    apart in it whenever ratio is within their :func:`ball_capacity`.
    """
    ratio = np.asarray(ratio, dtype=float)
    if np.any(ratio > n):
        raise ValueError('no balanced equilibrium: n m R < M eps')
    i = np.arange(1, n + 1) - (n + 1) / 2.0
    if n == 2:  # closed form, Eq. (34) in the corrected quadrant: delta/2 = acos(ratio/2)
        half = np.arccos(ratio / 2.0)
        return wrap_angle(math.pi - 2.0 * half[..., None] * i)
    # sin(n x) / sin(x) with x = delta / 2 falls monotonically from n (x = 0) to 0 (x = pi/n).
    lo = np.zeros_like(ratio)
    hi = np.full_like(ratio, math.pi / n)
    for _ in range(60):  # interval pi/n halved 60 times: below double round-off
        mid = 0.5 * (lo + hi)
        above = np.sin(n * mid) / np.sin(mid) > ratio
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    return wrap_angle(math.pi - (lo + hi)[..., None] * i)


def balanced_equilibrium(params: DriveParams, phi_star=None) -> BalancedEquilibrium:
    """Return the balanced equilibrium of Eq. (26) (symmetric fan, or the given ``phi_star``).

    A given ``phi_star`` [rad] must have n entries and satisfy Eq. (26) to :data:`EQ26_TOL`;
    otherwise :class:`ParamError` is raised naming ``phi_star``.
    """
    n = params.n
    ratio = params.M * params.eps / (params.m * params.R) if n > 0 else math.inf
    if phi_star is not None:
        phi = np.asarray(phi_star, dtype=float).reshape(-1)
        if phi.size != n or not np.all(np.isfinite(phi)):
            raise ParamError('phi_star', _deg(phi), f'{n} finite angles')
        res = eq26_residual(params, phi)
        if res > EQ26_TOL * max(n, 1):
            raise ParamError('phi_star', _deg(phi), 'a solution of Eq. (26)',
                             f'residual {res:.3g}')
        if not balls_apart(params, phi):
            raise ParamError('phi_star', _deg(phi), 'balls at least the contact separation '
                             f'2 asin(r_ball / R) = {math.degrees(params.contact_separation):.4g}'
                             ' deg apart', f'two are {math.degrees(min_spacing(phi)):.4g} deg '
                             'apart')
        return BalancedEquilibrium(True, phi)
    if n == 0:
        if params.eps == 0.0:
            return BalancedEquilibrium(True, np.zeros(0))
        return BalancedEquilibrium(False, np.zeros(0), 'no balls (n = 0) and eps > 0')
    if n == 1:
        if abs(ratio - 1.0) <= EQ26_TOL:
            return BalancedEquilibrium(True, np.array([math.pi]))
        return BalancedEquilibrium(False, np.zeros(0),
                                   'one ball balances only when m R = M eps exactly')
    capacity = ball_capacity(params)
    if ratio > capacity:
        return BalancedEquilibrium(False, np.zeros(0), no_equilibrium_reason(params))
    return BalancedEquilibrium(True, fan_phi_star(n, ratio))


def balanced_phi_star(params: DriveParams, phi_star=None) -> np.ndarray:
    """Return the balanced equilibrium's angles [rad]; ParamError naming eps where none exists."""
    eq = balanced_equilibrium(params, phi_star)
    if not eq.exists:
        raise ParamError('eps', params.eps, f'M eps <= n m R = {params.n * params.m * params.R:g} '
                         'kg m for a balanced equilibrium', eq.reason)
    return eq.phi_star


def no_equilibrium_reason(params: DriveParams) -> str:
    """Say why n >= 2 balls cannot balance the drive: its imbalance exceeds their capacity."""
    mR = params.m * params.R
    eps_max = ball_capacity(params) * mR / params.M
    limit = f'eps above {eps_max * 1e3:.3g} mm'
    if balls_touch(params):
        return ("the balls touch before they cancel the imbalance (packed "
                f"{math.degrees(params.contact_separation):.4g} deg apart they cancel at most "
                f"{ball_capacity(params):.4g} m R = {ball_capacity(params) * mR:.4g} < M eps = "
                f"{params.M * params.eps:.4g} kg m; {limit})")
    return (f"imbalance exceeds the balls' capacity: n m R = {params.n * mR:.4g} "
            f"< M eps = {params.M * params.eps:.4g} kg m ({limit})")


def least_spacing(params: DriveParams) -> float:
    """Return the smallest spacing [rad] of a balanced configuration's balls.

    The contact separation (less :data:`SPACING_TOL`) for balls that touch, else 0.
    """
    return params.contact_separation - SPACING_TOL if balls_touch(params) else 0.0


def balls_apart(params: DriveParams, phi) -> bool:
    """Return whether no two of the angles phi [rad] are closer than :func:`least_spacing`."""
    return min_spacing(phi) >= least_spacing(params)


def epsbar_lim(params: DriveParams) -> float:
    """Return the largest balanceable eccentricity eps/R = C m / M (Fig. 6; n = 2: 2 m R = M eps).

    C is the :func:`ball_capacity` (n for point masses).
    """
    return ball_capacity(params) * params.m / params.M


def mbar_lim(params: DriveParams) -> float:
    """Return the smallest ball mass m/M that can balance, eps / (C R) (Fig. 7).

    For n = 2: 2 m R = M eps. C is the :func:`ball_capacity` at the drive's r_ball (n for point
    masses).
    """
    if params.n == 0:
        return math.inf
    return params.eps / (ball_capacity(params) * params.R)


def _deg(phi) -> str:
    return '[' + ', '.join(f'{math.degrees(v):.6g} deg' for v in phi) + ']'

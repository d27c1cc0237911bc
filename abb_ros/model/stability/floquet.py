"""Floquet stability of one operating point and over two-parameter maps (Section 4, Eq. 39).

The monodromy of one periodic system (:class:`~abb_ros.model.stability.linear.PeriodicSystem`)
in physical units and its scipy reference; :func:`point_stability` (both planes at one
speed) and :func:`stability_map` (a grid of two Eq. (39) parameters). The compiled RK4
monodromy kernels are in :mod:`abb_ros.model.stability.monodromy`, the batched multipliers
and the removal of the balanced family's neutral directions in
:mod:`abb_ros.model.stability.floquet_batch`; their names are re-exported here, the
module callers import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from abb_ros.model.parameters.params import ParamError
from abb_ros.model.stability.equilibrium import balanced_equilibrium, epsbar_lim, mbar_lim
from abb_ros.model.stability.floquet_batch import (
    INVARIANCE_TOL,
    MAX_MEMBERS,
    PLANES,
    FamilyInvarianceError,
    MultiplierBatch,
    equilibria,
    max_multiplier,
    max_multiplier_batch,
    member_extremes,
    multipliers,
    multipliers_batch,
    sweep_speed,
    transverse_max_multiplier,
)
from abb_ros.model.stability.monodromy import (
    JIT,
    MAX_STEPS,
    MIN_STEPS,
    PY,
    SERIAL,
    STEPS_PER_RADIAN,
    monodromy_batch,
    steps_for,
)

__all__ = ['STEPS_PER_RADIAN', 'MIN_STEPS', 'MAX_STEPS', 'JIT', 'PY', 'SERIAL', 'monodromy_batch',
           'steps_for', 'monodromy', 'monodromy_reference', 'multipliers', 'max_multiplier',
           'PLANES',
           'equilibria', 'max_multiplier_batch', 'sweep_speed', 'PointStability',
           'point_stability', 'StabilityMap', 'stability_map', 'MAP_AXES', 'BALANCED', 'UNSTABLE',
           'NO_EQUILIBRIUM', 'INVARIANCE_TOL', 'FamilyInvarianceError', 'MultiplierBatch',
           'multipliers_batch', 'transverse_max_multiplier', 'member_extremes', 'MAX_MEMBERS']


def _to_physical(Phi_tau, omega):
    """Convert Phi for [x, dx/dtau] to [x, dx/dt] (similarity S Phi S^-1, S = diag(1, omega))."""
    nq = Phi_tau.shape[-1] // 2
    s = np.concatenate([np.ones(nq), np.full(nq, omega)])
    return Phi_tau * s[:, None] / s[None, :]


def monodromy(system, nsteps=None, kern=None) -> np.ndarray:
    """Compute Phi(T) of a :class:`~.stability.linear.PeriodicSystem`, state [x, x'] (SI)."""
    tau_end = system.omega * system.period
    if nsteps is None:
        nsteps = int(steps_for(fastest_rate(system), tau_end))
    Phi = monodromy_batch(system.M[None], system.C[None], system.K[None],
                          np.array([system.omega]), tau_end, nsteps, kern)[0]
    return _to_physical(Phi, system.omega)


def fastest_rate(system) -> float:
    """Estimate the largest |eigenvalue| of A(tau) in tau units over the period, plus 1."""
    rates = []
    for tau in np.linspace(0.0, 2 * math.pi, 9)[:-1]:
        A = system.state_matrix(tau / system.omega)
        rates.append(np.abs(np.linalg.eigvals(A)).max() / system.omega)
    return max(rates) + 1.0


def monodromy_reference(system, rtol=1e-12, atol=1e-12, method='DOP853') -> np.ndarray:
    """Compute Phi(T) by scipy's adaptive solve_ivp (the accuracy reference), state [x, x']."""
    from scipy.integrate import solve_ivp
    nq = system.M.shape[1]

    def fun(t, y):
        return (system.state_matrix(t) @ y.reshape(2 * nq, 2 * nq)).ravel()

    sol = solve_ivp(fun, (0.0, system.period), np.eye(2 * nq).ravel(), method=method,
                    rtol=rtol, atol=atol)
    return sol.y[:, -1].reshape(2 * nq, 2 * nq)


# ---- one operating point and two-parameter maps ----------------------------------------------

MAP_AXES = ('wbar', 'zeta', 'Dbar', 'epsbar', 'mbar', 'z_P', 'z_G', 'z_B', 'tau')
"""Parameters a stability map may vary (Eq. 39, and the offsets of docs/equations.md F4, F6,
whose maps are of the coupled linearisation: plane 'coupled')."""

BALANCED, UNSTABLE, NO_EQUILIBRIUM = 0, 1, 2
"""Map status codes: balanced and stable (|lambda|max < 1); balanced equilibrium unstable;
no balanced equilibrium (n m R < M eps). Both of the last two are 'unbalanced'."""


@dataclass(frozen=True)
class PointStability:
    """Stability of the balanced equilibrium at one operating point (Section 4).

    ``lam_in``/``lam_out``: largest |transverse multiplier| per plane; ``neutral``: the
    family's neutral in-plane multipliers removed; ``invariance``: their self-check
    ||Phi V - V||; ``member``: which equilibrium of the family was evaluated. A drive with
    heights (docs/equations.md F4) has one coupled value in both ``lam_in`` and ``lam_out``
    (``coupled`` True, :mod:`abb_ros.model.stability.coupled`) and its predicted
    ``residual_tilt`` [rad].
    """

    omega: float
    exists: bool
    phi_star: np.ndarray
    lam_in: float
    lam_out: float
    reason: str = ''
    neutral: int = 0
    invariance: float = 0.0
    member: str = 'symmetric fan'
    coupled: bool = False
    residual_tilt: float = math.nan

    @property
    def lam_max(self) -> float:
        """Largest |multiplier| over a spindle period T (out-of-plane group: over T/2, squared)."""
        return self.lam_in if self.coupled else max(self.lam_in, self.lam_out ** 2)

    @property
    def balanced(self) -> bool:
        """True when the balanced equilibrium exists and both planes are stable."""
        return self.exists and self.lam_in < 1.0 and self.lam_out < 1.0

    @property
    def verdict(self) -> str:
        """Verdict in words: 'balanced', or 'unbalanced (...)' saying why."""
        if not self.exists:
            return 'unbalanced (no balanced equilibrium)'
        if self.balanced:
            return 'balanced'
        if self.coupled:
            return 'unbalanced (coupled linearisation unstable)'
        planes = [name for name, lam in (('in-plane', self.lam_in), ('out-of-plane', self.lam_out))
                  if lam >= 1.0]
        return 'unbalanced (' + ' and '.join(planes) + ' unstable)'


def point_stability(params, omega, phi_star=None, member=None) -> PointStability:
    """Compute in-plane and out-of-plane |lambda|max at the balanced equilibrium.

    ``phi_star`` : a member of the family [rad] (checked against Eq. 26), default the
    symmetric fan; ``member`` names it in the result (default 'symmetric fan' or 'given').
    With heights (F4) the coupled linearisation's lam_max and the predicted residual tilt.
    """
    eq = balanced_equilibrium(params, phi_star)
    name = member or ('symmetric fan' if phi_star is None else 'given')
    if not eq.exists:
        return PointStability(float(omega), False, eq.phi_star, math.inf, math.inf, eq.reason,
                              member=name, coupled=params.off_plane)
    if params.off_plane:
        return _coupled_point(params, omega, eq.phi_star, name)
    res = {plane: multipliers_batch([params], [omega], plane, eq.phi_star)
           for plane in ('in', 'out')}
    return PointStability(float(omega), True, eq.phi_star, float(res['in'].lam[0]),
                          float(res['out'].lam[0]), neutral=int(res['in'].neutral[0]),
                          invariance=float(res['in'].invariance[0]), member=name)


def _coupled_point(params, omega, phi, name) -> PointStability:
    """Return the coupled system's PointStability (both planes' fields hold lam_max)."""
    from abb_ros.model.stability import coupled
    cs = coupled.coupled_system(params, omega, phi)
    st = coupled.stability_of(cs)
    return PointStability(float(omega), True, phi, st.lam_max, st.lam_max, neutral=st.neutral,
                          invariance=st.invariance, member=name, coupled=True,
                          residual_tilt=coupled.tilt_of(cs))


@dataclass
class StabilityMap:
    """|lambda|max and status over a grid: arrays shape (len(y_values), len(x_values)).

    ``lam`` is +inf where no balanced equilibrium exists (status NO_EQUILIBRIUM).
    ``fixed`` holds the settings applied to every point and the resulting dimensionless and SI
    parameters (at the first grid point's non-axis values); ``limits`` the horizontal limit
    lines of Figs. 6 and 7 (epsbar_lim, mbar_lim) that apply to the y axis. ``lam`` and
    ``status`` are the symmetric fan's; with ``members`` > 0, ``lam_best``/``lam_worst`` are
    the best and worst over that many sampled members of the family (:func:`member_extremes`;
    ``members`` is the fewest found at a point).
    """

    x: str
    y: str
    x_values: np.ndarray
    y_values: np.ndarray
    lam: np.ndarray
    status: np.ndarray
    plane: str
    fixed: dict
    limits: dict
    lam_best: np.ndarray | None = None
    lam_worst: np.ndarray | None = None
    members: int = 0

    def summary(self) -> dict:
        """Return the map's axes, plane, balanced fractions and |lambda|max range as a dict."""
        n = self.status.size
        out = {'x': self.x, 'y': self.y, 'plane': self.plane, 'points': int(n),
               'balanced_fraction': float((self.status == BALANCED).mean()),
               'no_equilibrium_fraction': float((self.status == NO_EQUILIBRIUM).mean()),
               'lam_max_finite_range': _finite_range(self.lam), 'limits': self.limits,
               'fixed': self.fixed}
        if self.lam_best is not None:
            out.update(members_sampled=self.members,
                       balanced_fraction_best_member=float((self.lam_best < 1.0).mean()),
                       balanced_fraction_worst_member=float((self.lam_worst < 1.0).mean()))
        return out


def _finite_range(lam):
    fin = lam[np.isfinite(lam)]
    return [float(fin.min()), float(fin.max())] if fin.size else []


def stability_map(base, x, x_values, y, y_values,
                  settings=None, plane='in', progress=None, members=0) -> StabilityMap:
    """Compute |lambda|max over the grid x_values x y_values of two Eq. (39) parameters.

    base : DriveParams; settings : further fixed settings for apply_settings (e.g. zeta, wbar);
    every point is converted with :func:`abb_ros.model.parameters.params.apply_settings`. wbar must
    be one of the axes or in ``settings``.
    """
    settings = _map_settings(x, y, settings)
    xs = np.asarray(x_values, dtype=float)
    ys = np.asarray(y_values, dtype=float)
    plist, omegas = _grid_drives(base, x, xs, y, ys, settings)
    if plane == 'coupled' or any(p.off_plane for p in plist):
        if members:
            raise ParamError('members', members, '0 for a map of the coupled linearisation')
        from abb_ros.model.stability.coupled import lam_max_batch
        plane = 'coupled'
        res = lam_max_batch(plist, np.maximum(omegas, 1e-9), progress)
        lam, exists = res.lam, res.exists
    else:
        lam, exists = max_multiplier_batch(plist, np.maximum(omegas, 1e-9), plane,
                                           progress=progress)
    status = np.where(~exists, NO_EQUILIBRIUM, np.where(lam < 1.0, BALANCED, UNSTABLE))
    first = plist[0]
    fixed = {'settings': settings, 'n': first.n, 'omega0': first.omega0,
             **{k: v for k, v in first.dimensionless().items() if k not in (x, y)},
             'SI': {k: v for k, v in first.as_dict().items()}}
    shape = (ys.size, xs.size)
    smap = StabilityMap(x, y, xs, ys, lam.reshape(shape), status.reshape(shape), plane, fixed,
                        _limits(first, (x, y)))
    if members:
        best, worst, sampled = member_extremes(plist, np.maximum(omegas, 1e-9), plane, members,
                                               progress, fan_lam=lam)
        smap.lam_best, smap.lam_worst = best.reshape(shape), worst.reshape(shape)
        smap.members = int(sampled[exists].min()) if exists.any() else 0
    return smap


def _map_settings(x, y, settings) -> dict:
    """Return the fixed settings of a map over axes ``x`` and ``y``, the axes checked."""
    for name in (x, y):
        if name not in MAP_AXES:
            raise ParamError('axis', name, 'one of ' + ', '.join(MAP_AXES))
    if x == y:
        raise ParamError('axis', y, 'a parameter other than the x axis')
    settings = dict(settings or {})
    for name in (x, y):
        settings.pop(name, None)
    if 'wbar' not in (x, y) and 'wbar' not in settings and 'omega' not in settings:
        raise ParamError('wbar', None, '[0, inf): give it as an axis or with --set wbar=...')
    return settings


def _grid_drives(base, x, xs, y, ys, settings) -> tuple[list, np.ndarray]:
    """Return the drive and the speed of every grid point, row by row (y outer).

    A drive is built once for the points that differ only in speed.
    """
    from abb_ros.model.parameters.params import apply_settings
    cache = {}
    plist, omegas = [], []
    for yv in ys:
        for xv in xs:
            point = {**settings, x: float(xv), y: float(yv)}
            speed = {k: point.pop(k) for k in ('wbar', 'omega') if k in point}
            key = tuple(sorted(point.items()))
            if key not in cache:
                cache[key] = apply_settings(base, point)[0]
            params, omega = apply_settings(cache[key], speed)
            plist.append(params)
            omegas.append(omega)
    return plist, np.asarray(omegas)


def _limits(first, axes) -> dict:
    """Return the balancing limits of the map's first drive for its mass or eccentricity axis."""
    limits = {}
    if 'mbar' in axes:
        limits['mbar_lim'] = mbar_lim(first)
    if 'epsbar' in axes:
        limits['epsbar_lim'] = epsbar_lim(first)
    return limits

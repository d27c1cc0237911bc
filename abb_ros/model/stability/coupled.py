"""The coupled linearisation about the balanced position, taken from the nonlinear rows (F5).

With P, G or the race off the washers' plane (docs/equations.md, F4) the in-plane and
out-of-plane groups of Eqs. (27)-(33) no longer decouple. Here the linearisation of the whole
system x = [X, Y, Z, alpha, beta, gamma, phi_1..phi_n] comes from the one implementation of the
nonlinear rows (:func:`abb_ros.model.dynamics.equations.lagrange_residual`) at the balanced
position: deck at rest, balls at phi* (Eq. 26), theta = tau, theta' = omega. The mass matrix is
the rows' derivative in q'' (they are linear in it, so the difference is exact); damping and
stiffness are central differences in q' and q; each is sampled at :data:`SAMPLES` angles tau over
one period T = 2 pi / omega and turned into harmonics up to order 2 (a real DFT; the higher
harmonics must vanish, which is checked, so the result is the linearisation, not a fit). The
rows at that position, with the sign changed, are the forcing F(tau) of

    M(tau) x'' + C(tau) x' + K(tau) x = F(tau):

zero in the plane (the balls cancel the imbalance, Eq. 26) and the couple of the imbalance where
the balls are not in G's plane. The largest |multiplier| of the monodromy over T is ``lam_max``;
for zero heights it equals the larger of the in-plane value and the square of the out-of-plane
one (whose period is T / 2), which the tests check against Eqs. (27)-(33). The periodic solution
of the forced system is the residual tilt a single race leaves (:func:`periodic_response`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from abb_ros.model.dynamics.equations import lagrange_residual
from abb_ros.model.dynamics.state import DECK_NAMES, PHI, THETA, n_coords
from abb_ros.model.parameters.params import DriveParams, ParamError
from abb_ros.model.stability.equilibrium import balanced_equilibrium, balanced_phi_star
from abb_ros.model.stability.family import tangent_frame
from abb_ros.model.stability.floquet_batch import (
    FamilyInvarianceError,
    MultiplierBatch,
    max_multiplier,
    rate_estimate,
    refuse_over_step_limit,
    transverse_max_multiplier,
)
from abb_ros.model.stability.linear import PeriodicSystem, harmonic_basis, named_modes
from abb_ros.model.stability.linear import natural_frequencies as linear_natural_frequencies
from abb_ros.model.stability.monodromy import STEPS_PER_RADIAN, monodromy_batch, steps_for

__all__ = ['COORDS', 'CoupledSystem', 'CoupledStability', 'coupled_system', 'coupled_stability',
           'periodic_response', 'residual_tilt', 'SAMPLES', 'ORDER', 'SpeedPolynomial',
           'speed_polynomial', 'lam_max_sweep', 'lam_max_batch', 'natural_frequencies',
           'stability_of', 'tilt_of', 'deck_natural_frequencies']

COORDS = DECK_NAMES
"""The deck's coordinates of the coupled system; the ball angles phi_1..phi_n follow."""

SAMPLES = 16
"""Angles tau per period at which the rows are linearised (8 times the highest harmonic)."""

ORDER = 2
"""Highest harmonic of the coefficients in tau (the sin^2, sin cos of Eqs. 29-31)."""

STEP = 1e-6
"""Central-difference step in every coordinate [m, rad] and rate [m/s, rad/s]. The rows are
polynomials in the rates (exact under central differences up to quadratics) and smooth in the
coordinates (truncation ~ STEP^2 / 6 relative); round-off ~ 1e-16 / STEP of the row scale."""

HARMONIC_TOL = 1e-7
"""Largest harmonic above :data:`ORDER`, relative to the largest coefficient, accepted."""


@dataclass(frozen=True)
class CoupledSystem:
    """The coupled linearisation: ``system`` (M, C, K harmonics, period T) and the forcing F.

    ``F`` : harmonics of the forcing, shape (2 ORDER + 1, 6 + n) (same basis as M, C, K).
    ``phi_star`` : the balanced equilibrium it is taken at [rad].
    """

    system: PeriodicSystem
    F: np.ndarray
    phi_star: np.ndarray

    def forcing(self, t: float) -> np.ndarray:
        """Return F(t), shape (6 + n,)."""
        return harmonic_basis(self.system.omega * t, ORDER) @ self.F


@dataclass(frozen=True)
class CoupledStability:
    """``lam_max`` over T of the whole linearisation; ``neutral`` family directions removed."""

    omega: float
    lam_max: float
    neutral: int
    invariance: float


def _rows_at(params: DriveParams, omega: float, phi: np.ndarray, tau: float):
    """Return (M, C, K, F) of the rows at the balanced position at angle tau."""
    n = params.n
    N = n_coords(n)
    y0 = np.zeros(2 * N)
    y0[THETA] = tau
    y0[PHI:N] = phi
    y0[N + THETA] = omega
    zero = np.zeros(N)
    r0 = lagrange_residual(params, y0, zero)
    nq = N - 1
    M, C, K = (np.empty((nq, nq)) for _ in range(3))
    for j in range(nq):
        e = np.zeros(N)
        e[1 + j] = 1.0
        M[:, j] = lagrange_residual(params, y0, e) - r0
        for out, offset in ((K, 0), (C, N)):
            dy = np.zeros(2 * N)
            dy[offset + 1 + j] = STEP
            out[:, j] = (lagrange_residual(params, y0 + dy, zero)
                         - lagrange_residual(params, y0 - dy, zero)) / (2 * STEP)
    return M, C, K, -r0


def _harmonics(samples: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """Return the harmonics (1, cos, sin, ... up to ORDER) of samples over one period, checked.

    ``floor``: the least scale the higher harmonics are compared with (the forcing is zero to
    round-off in the plane, so its own size is no scale).
    """
    S = samples.shape[0]
    tau = 2 * math.pi * np.arange(S) / S
    out = [samples.mean(axis=0)]
    scale = max(np.abs(samples).max(), floor, 1e-300)
    for j in range(1, S // 2):
        a = 2.0 / S * np.tensordot(np.cos(j * tau), samples, axes=1)
        b = 2.0 / S * np.tensordot(np.sin(j * tau), samples, axes=1)
        if j <= ORDER:
            out += [a, b]
        elif (size := max(np.abs(a).max(), np.abs(b).max()) / scale) > HARMONIC_TOL:
            raise RuntimeError(f'the linearised rows hold harmonic {j} of the spindle angle '
                               f'(relative size {size:.2g}); the coupled analysis assumes '
                               f'order <= {ORDER}')
    return np.array(out)


def _linearised(params: DriveParams, omega: float, phi, floor_speed: float):
    """Return the harmonics (M, C, K, F) of the rows at the balanced position at omega."""
    taus = 2 * math.pi * np.arange(SAMPLES) / SAMPLES
    rows = [_rows_at(params, omega, phi, tau) for tau in taus]
    M, C, K = (_harmonics(np.array([r[i] for r in rows])) for i in range(3))
    F = _harmonics(np.array([r[3] for r in rows]), params.M * params.eps * floor_speed ** 2)
    return M, C, K, F


def _coords(n: int) -> tuple:
    return COORDS + tuple(f'phi_{i + 1}' for i in range(n))


def coupled_system(params: DriveParams, omega: float, phi_star=None) -> CoupledSystem:
    """Return the coupled linearisation at the balanced equilibrium (symmetric fan or given)."""
    _check_omega(omega)
    phi = balanced_phi_star(params, phi_star)
    M, C, K, F = _linearised(params, omega, phi, omega)
    return CoupledSystem(PeriodicSystem(M, C, K, float(omega), 2 * math.pi / omega,
                                        _coords(params.n)), F, phi)


def _check_omega(omega) -> None:
    omega = np.asarray(omega, dtype=float)
    if omega.size and not (np.all(np.isfinite(omega)) and np.all(omega > 0)):
        bad = omega[~(np.isfinite(omega) & (omega > 0))].flat[0]
        raise ParamError('omega', float(bad), '(0, inf) rad/s')


INVARIANCE_TOL = 1e-6
"""Largest ||Phi V - V|| of the family's tangent directions V accepted as neutral. The
finite-difference stiffness holds K V = 0 to ~1e-10 of K (measured invariance 1e-10 to 3e-9
for n = 3, 4), not to the round-off of Eqs. (27)-(33) (floquet_batch.INVARIANCE_TOL)."""


def _transverse(Phi, U, k: int):
    """Return lam_max with the k neutral family directions U removed (self-checked)."""
    lam, invariance = transverse_max_multiplier(
        Phi, np.broadcast_to(U, (Phi.shape[0],) + U.shape), k, first_ball=len(COORDS))
    if invariance.max() > INVARIANCE_TOL:
        raise FamilyInvarianceError('the balanced family\'s tangent directions are not '
                                    'neutral in the coupled linearisation (||Phi V - V|| = '
                                    f'{invariance.max():.3g}): no stability verdict')
    return lam, invariance


SPEED_TOL = 1e-8
"""Largest misfit of the speed polynomial at a fourth speed, relative to the coefficients."""


@dataclass(frozen=True)
class SpeedPolynomial:
    """The coupled linearisation at every speed: coefficients c0 + c1 omega + c2 omega^2.

    theta' = omega enters the rows as a rate, and the rows are at most quadratic in the rates
    (centrifugal and Coriolis terms), so M, C, K and F are polynomials of degree 2 in omega:
    three speeds give every speed exactly (a fourth checks it, :func:`speed_polynomial`).
    Each of ``M, C, K, F`` holds the harmonics of (c0, c1, c2), shape (3, 2 ORDER + 1, ...).
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    F: np.ndarray
    phi_star: np.ndarray

    def at(self, omegas) -> tuple:
        """Return the harmonics (M, C, K, F) at omegas [rad/s], each with a leading axis (B,)."""
        w = np.asarray(omegas, dtype=float).reshape(-1)
        powers = np.stack([np.ones_like(w), w, w ** 2], axis=-1)
        return tuple(np.tensordot(powers, H, axes=1) for H in (self.M, self.C, self.K, self.F))


def speed_polynomial(params: DriveParams, phi_star=None) -> SpeedPolynomial:
    """Return the coupled linearisation as a polynomial in the spindle speed (checked)."""
    phi = balanced_phi_star(params, phi_star)
    s = params.omega0
    at = [_linearised(params, w, phi, s) for w in (0.0, s, 2.0 * s, 3.0 * s)]
    coef = []
    for i in range(4):
        h0, h1, h2, h3 = (a[i] for a in at)
        c2 = (h2 - 2.0 * h1 + h0) / (2.0 * s * s)
        c1 = (h1 - h0) / s - c2 * s
        scale = max(np.abs(h3).max(), np.abs(h2).max(), params.M * params.eps * s * s * 1e-3)
        if np.abs(h0 + 3.0 * s * c1 + 9.0 * s * s * c2 - h3).max() > SPEED_TOL * scale:
            raise RuntimeError('the linearised rows are not quadratic in the spindle speed')
        coef.append(np.stack([h0, c1, c2]))
    return SpeedPolynomial(*coef, phi)


def lam_max_sweep(params: DriveParams, omegas, phi_star=None) -> np.ndarray:
    """Return lam_max (over T = 2 pi / omega) of the coupled linearisation at each speed.

    One :class:`SpeedPolynomial` and one batch of compiled monodromies; the balanced
    family's neutral directions removed (their self-check as in the in-plane batch).
    """
    omegas = np.asarray(omegas, dtype=float).reshape(-1)
    _check_omega(omegas)
    poly = speed_polynomial(params, phi_star)
    Mh, Ch, Kh, _ = poly.at(omegas)
    return _lam_max(Mh, Ch, Kh, omegas, poly.phi_star)[0]


def _lam_max(Mh, Ch, Kh, omegas, phi):
    """Return (lam_max (B,), neutral k, invariance (B,)) of a batch of coupled systems at phi.

    The monodromy over T by the compiled RK4 kernels at the steps of each point's fastest rate
    (a speed needing more than the stated maximum is refused, naming omega); where the
    balanced equilibria form a family (n >= 3, or n = 2 at eps = 0) its tangent directions
    are neutral (multipliers exactly 1) and are removed, as for the in-plane group.
    """
    tau_end = 2 * math.pi
    rate = rate_estimate(Mh, Ch, Kh, omegas)
    i = int(np.argmax(rate))
    refuse_over_step_limit(STEPS_PER_RADIAN * float(rate[i]) * tau_end, float(omegas[i]))
    Phi = monodromy_batch(Mh, Ch, Kh, omegas, tau_end, steps_for(rate, tau_end))
    U, k = tangent_frame(phi)
    if k == 0:
        return max_multiplier(Phi), 0, np.zeros(len(omegas))
    lam, invariance = _transverse(Phi, U, int(k))
    return lam, int(k), invariance


def lam_max_batch(params_list, omegas, progress=None) -> MultiplierBatch:
    """Return lam_max of a batch of (drive, speed) pairs, as the plane's batches do.

    The pairs of one drive share one speed batch (drives compare by value); lam +inf and
    exists False where the drive has no balanced equilibrium. ``progress(k)`` is called with
    the number of pairs done after each drive.
    """
    omegas = np.asarray(omegas, dtype=float).reshape(-1)
    lam = np.full(len(params_list), np.inf)
    exists = np.zeros(len(params_list), dtype=bool)
    neutral = np.zeros(len(params_list), dtype=np.int64)
    invariance = np.zeros(len(params_list))
    groups = {}
    for i, p in enumerate(params_list):
        groups.setdefault(p, []).append(i)
    for params, idx in groups.items():
        eq = balanced_equilibrium(params)
        if eq.exists:
            exists[idx] = True
            Mh, Ch, Kh, _ = speed_polynomial(params, eq.phi_star).at(omegas[idx])
            lam[idx], neutral[idx], invariance[idx] = _lam_max(Mh, Ch, Kh, omegas[idx],
                                                               eq.phi_star)
        if progress is not None:
            progress(len(idx))
    return MultiplierBatch(lam, exists, neutral, invariance)


def natural_frequencies(params: DriveParams) -> dict:
    """Return the deck's undamped natural frequencies [rad/s] with the heights, m = omega = 0.

    The coupled deck rows (X, Y, Z, alpha, beta, gamma) at rest, without balls and with the
    rotor's mass on its axis (eps = 0); for zero heights the values of
    :func:`abb_ros.model.stability.linear.natural_frequencies` to 1e-8 (which keep eps's
    first-order mass terms: 1e-5 apart at Table 1).
    """
    bare = dataclasses.replace(params, n=0, eps=0.0)
    M, _, K, _ = _rows_at(bare, 0.0, np.zeros(0), 0.0)
    return named_modes(M, K, COORDS)


def deck_natural_frequencies(params: DriveParams) -> dict:
    """Return the natural frequencies a drive's analysis names [rad/s].

    Section 4's of Eqs. (27)-(32) in the washers' plane
    (:func:`abb_ros.model.stability.linear.natural_frequencies`), the coupled deck's
    (:func:`natural_frequencies`) where heights or a leaning axis couple the groups.
    """
    return (natural_frequencies if params.off_plane else linear_natural_frequencies)(params)


def coupled_stability(params: DriveParams, omega: float, phi_star=None) -> CoupledStability:
    """Return lam_max, the largest |Floquet multiplier| over T of the coupled linearisation."""
    return stability_of(coupled_system(params, omega, phi_star))


def stability_of(cs: CoupledSystem) -> CoupledStability:
    """Return the :class:`CoupledStability` of a coupled system (see :func:`_lam_max`)."""
    system = cs.system
    omega = np.array([system.omega])
    lam, k, invariance = _lam_max(system.M[None], system.C[None], system.K[None], omega,
                                  cs.phi_star)
    return CoupledStability(system.omega, float(lam[0]), k, float(invariance[0]))


def periodic_response(cs: CoupledSystem, samples: int = 256, rtol: float = 1e-10):
    """Return (t (samples,), x (samples, 2 (6 + n))): the T-periodic solution of the forced system.

    y' = A(t) y + g(t), y = [x, x'], g = [0; M^-1 F]: the fundamental matrix and a particular
    solution from rest are integrated together over T (scipy's DOP853 at ``rtol``), y(0) solves
    (I - Phi) y(0) = y_p(T) (least squares: a neutral family direction does not move the deck),
    and the periodic solution is integrated once more from y(0).
    """
    from scipy.integrate import solve_ivp
    system = cs.system
    nq = system.M.shape[1]
    m = 2 * nq

    def state_and_forcing(t):
        """Return A(t) of y' = A y + g and g(t), from one evaluation of M, C, K."""
        M, C, K = system.at(t)
        A = np.zeros((m, m))
        A[:nq, nq:] = np.eye(nq)
        A[nq:] = -np.linalg.solve(M, np.hstack([K, C]))
        return A, np.concatenate([np.zeros(nq), np.linalg.solve(M, cs.forcing(t))])

    def fundamental(t, y):
        A, g = state_and_forcing(t)
        return np.concatenate([(A @ y[:m * m].reshape(m, m)).ravel(), A @ y[m * m:] + g])

    def forced(t, y):
        A, g = state_and_forcing(t)
        return A @ y + g

    T = system.period
    start = np.concatenate([np.eye(m).ravel(), np.zeros(m)])
    end = solve_ivp(fundamental, (0.0, T), start, method='DOP853', rtol=rtol,
                    atol=1e-14).y[:, -1]
    Phi, yp = end[:m * m].reshape(m, m), end[m * m:]
    y0 = np.linalg.lstsq(np.eye(m) - Phi, yp, rcond=None)[0]
    t = np.linspace(0.0, T, samples, endpoint=False)
    sol = solve_ivp(forced, (0.0, T), y0, method='DOP853', rtol=rtol, atol=1e-16, t_eval=t)
    return sol.t, sol.y.T


def residual_tilt(params: DriveParams, omega: float, phi_star=None) -> float:
    """Return the predicted residual tilt [rad]: max sqrt(alpha^2 + beta^2) of the periodic reply.

    Zero (to round-off) where the balls cancel both the force and the couple of the imbalance.
    """
    return tilt_of(coupled_system(params, omega, phi_star))


def tilt_of(cs: CoupledSystem) -> float:
    """Return the residual tilt [rad] of a coupled system's periodic response."""
    _, x = periodic_response(cs)
    al, be = COORDS.index('alpha'), COORDS.index('beta')
    return float(np.hypot(x[:, al], x[:, be]).max())

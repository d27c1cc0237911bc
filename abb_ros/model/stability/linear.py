"""Linearised equations about the balanced equilibrium, Eqs. (27)-(33), and natural frequencies.

The coefficient matrices are trigonometric polynomials in the spindle angle tau = omega t,
stored as harmonics: ``H[0] + H[1] cos tau + H[2] sin tau (+ H[3] cos 2 tau + H[4] sin 2 tau)``.

In-plane, Eqs. (27), (28), (32), (33): X_I = [X, Y, gamma, phi_1..phi_n], period T_I = 2 pi/omega,
harmonics up to order 1. Eq. (33) is printed with X' and Y'; the ball equation (24) it
linearises has X'' and Y'' (the inertial force on the ball from the accelerating race), so the
ball rows here couple through the *mass* matrix, which keeps M_I symmetric.

Out-of-plane, Eqs. (29)-(31): X_O = [Z, alpha, beta], harmonics up to order 2 (sin^2, sin cos),
period T_O = T_I / 2.

Every builder accepts array-valued parameters (shape (B,)) as well as scalars, so a whole map
is assembled in one vectorised call; outputs then have shape (B, H, nq, nq).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import scipy.linalg

from abb_ros.model.parameters.drive_spec import OFF_PLANE
from abb_ros.model.parameters.params import DriveParams, ParamError, zero_text
from abb_ros.model.stability.equilibrium import balanced_phi_star

__all__ = ['PeriodicSystem', 'in_plane', 'out_of_plane', 'in_plane_harmonics',
           'out_of_plane_harmonics', 'natural_frequencies', 'stack_params', 'harmonic_basis']

_FIELDS = ('a', 'b', 'd', 'R', 'M_P', 'M', 'm', 'J_Px', 'J_Py', 'J_Pz', 'J_x', 'J_y', 'J_z',
           'k', 'c', 'D', 'eps')


def harmonic_basis(tau, order: int) -> np.ndarray:
    """Return [1, cos tau, sin tau, cos 2tau, ...] up to ``order``, shape (..., 2 order + 1).

    A scalar tau gives one row (the coefficients' basis at that angle), an array of angles a
    row each (a design matrix, e.g. the fit of a run's residual tilt).
    """
    tau = np.asarray(tau, dtype=float)
    parts = [np.ones_like(tau)]
    for j in range(1, order + 1):
        parts += [np.cos(j * tau), np.sin(j * tau)]
    return np.stack(parts, axis=-1)


@dataclass(frozen=True)
class PeriodicSystem:
    """M(t) x'' + C(t) x' + K(t) x = 0 with coefficients periodic in tau = omega t (SI).

    ``M, C, K`` : ndarray, shape (2 order + 1, nq, nq), harmonics in tau (see module doc).
    ``period`` : T [s] (T_I = 2 pi/omega in-plane, T_O = pi/omega out-of-plane).
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    omega: float
    period: float
    coords: tuple

    def at(self, t: float):
        """Return (M(t), C(t), K(t)), each shape (nq, nq)."""
        basis = harmonic_basis(self.omega * t, (self.M.shape[0] - 1) // 2)
        return tuple(np.tensordot(basis, H, axes=1) for H in (self.M, self.C, self.K))

    def state_matrix(self, t: float) -> np.ndarray:
        """Return A(t) of the first-order form y' = A(t) y, y = [x, x'], shape (2 nq, 2 nq)."""
        M, C, K = self.at(t)
        nq = M.shape[0]
        A = np.zeros((2 * nq, 2 * nq))
        A[:nq, nq:] = np.eye(nq)
        A[nq:, :nq] = -np.linalg.solve(M, K)
        A[nq:, nq:] = -np.linalg.solve(M, C)
        return A


def check_in_plane(params: DriveParams) -> None:
    """Refuse P, G or the race off the washers' plane: Eqs. (27)-(33) linearise the plane's model.

    With heights the in-plane and out-of-plane groups no longer decouple (docs/equations.md,
    F4); :mod:`abb_ros.model.stability.coupled` linearises such a drive as one system, and a
    verdict of the decoupled groups would be wrong, so none is given here.
    """
    for name in OFF_PLANE:
        value = params.value(name)
        if value != 0.0:
            raise ParamError(name, value, f'{zero_text(name)} for the Floquet analysis of '
                             'Eqs. (27)-(33)',
                             'with mass centres off the plane or a second race the groups '
                             'couple: abb_ros.model.stability.coupled analyses such a drive')


def stack_params(plist) -> SimpleNamespace:
    """Stack a list of DriveParams (same n) into a namespace of arrays, shape (B,)."""
    for params in plist:
        check_in_plane(params)
    ns = {f: np.array([getattr(p, f) for p in plist], dtype=float) for f in _FIELDS}
    ns['n'] = plist[0].n
    return SimpleNamespace(**ns)


def _trig_sums(phi):
    """Return the ball sums' harmonic parts, sum cos(phi*) and sum sin(phi*), each shape batch."""
    return np.cos(phi), np.sin(phi)


def in_plane_harmonics(p, omega, phi_star):
    """Return the (M, C, K) harmonics of Eqs. (27), (28), (32), (33).

    Each has shape batch + (3, 3+n, 3+n). ``p`` has attributes of DriveParams (scalars or arrays of
    shape (B,)), ``omega`` [rad/s] scalar or (B,), ``phi_star`` [rad] shape (n,) or (B, n).
    """
    omega = np.asarray(omega, dtype=float)
    phi = np.asarray(phi_star, dtype=float)
    n = phi.shape[-1]
    batch = np.broadcast_shapes(omega.shape, phi.shape[:-1], np.shape(p.m), np.shape(p.c))
    nq = 3 + n
    Mh, Ch, Kh = (np.zeros(batch + (3, nq, nq)) for _ in range(3))
    bc = lambda v: np.broadcast_to(np.asarray(v, dtype=float), batch)  # noqa: E731
    m, R, d, M_P, c, k = (bc(v) for v in (p.m, p.R, p.d, p.M_P, p.c, p.k))
    Mt = bc(p.M + p.M_P + n * p.m)
    Jg = bc(p.J_z + p.J_Pz + p.M_P * p.d ** 2 + p.M * p.eps ** 2 + n * p.m * p.R ** 2)
    G = bc(p.a ** 2 + p.b ** 2 + 4 * p.d ** 2)
    w = bc(omega)
    X, Y, g = 0, 1, 2
    # X-Y-gamma block, constant (harmonic 0)
    for H, cXX, cXg, cgg in ((Mh, Mt, d * M_P, Jg), (Ch, 4 * c, 4 * d * c, G * c),
                             (Kh, 4 * k, 4 * d * k, G * k)):
        H[..., 0, X, X] = cXX
        H[..., 0, Y, Y] = cXX
        H[..., 0, X, g] = H[..., 0, g, X] = cXg
        H[..., 0, g, g] = cgg
    # sin(phi*+tau) = sin(phi*) cos tau + cos(phi*) sin tau ; cos(phi*+tau) = cos cos - sin sin
    cphi, sphi = _trig_sums(phi)
    s_h = (np.broadcast_to(sphi, batch + (n,)), np.broadcast_to(cphi, batch + (n,)))
    c_h = (np.broadcast_to(cphi, batch + (n,)), np.broadcast_to(-sphi, batch + (n,)))
    mR = (m * R)[..., None]
    mR2 = (m * R * R)[..., None]
    D = bc(p.D)[..., None]
    for i in range(n):
        col = 3 + i
        for j, (s, cc) in enumerate(zip(s_h, c_h), start=1):  # harmonics cos tau, sin tau
            si, ci = s[..., i], cc[..., i]
            # Eq. (27): -mR [(phi'' - w^2 phi) sin + 2 w phi' cos]
            Mh[..., j, X, col] = -mR[..., 0] * si
            Ch[..., j, X, col] = -2 * mR[..., 0] * w * ci
            Kh[..., j, X, col] = mR[..., 0] * w ** 2 * si
            # Eq. (28): +mR [(phi'' - w^2 phi) cos - 2 w phi' sin]
            Mh[..., j, Y, col] = mR[..., 0] * ci
            Ch[..., j, Y, col] = -2 * mR[..., 0] * w * si
            Kh[..., j, Y, col] = -mR[..., 0] * w ** 2 * ci
            # Eq. (33) with X'', Y'': -mR (X'' sin - Y'' cos)
            Mh[..., j, col, X] = -mR[..., 0] * si
            Mh[..., j, col, Y] = mR[..., 0] * ci
        Mh[..., 0, g, col] = Mh[..., 0, col, g] = mR2[..., 0]   # Eq. (32) and (33)
        Mh[..., 0, col, col] = mR2[..., 0]
        Ch[..., 0, col, col] = D[..., 0]
    return Mh, Ch, Kh


def out_of_plane_harmonics(p, omega, phi_star):
    """Return the (M, C, K) harmonics of Eqs. (29)-(31), each shape batch + (5, 3, 3)."""
    omega = np.asarray(omega, dtype=float)
    phi = np.asarray(phi_star, dtype=float)
    batch = np.broadcast_shapes(omega.shape, phi.shape[:-1], np.shape(p.m), np.shape(p.c))
    Mh, Ch, Kh = (np.zeros(batch + (5, 3, 3)) for _ in range(3))
    bc = lambda v: np.broadcast_to(np.asarray(v, dtype=float), batch)  # noqa: E731
    n = phi.shape[-1]
    d, M_P, c, k, w = (bc(v) for v in (p.d, p.M_P, p.c, p.k, omega))
    Me2 = bc(p.M * p.eps ** 2)
    mR2 = bc(p.m * p.R ** 2)
    # sum over G (weight M eps^2, angle 0) and balls (mR^2, phi*) of sin^2, cos^2, sin cos of
    # (angle + tau): I0/2 -+ (Ac cos 2tau - As sin 2tau)/2 and (As cos 2tau + Ac sin 2tau)/2
    I0 = Me2 + n * mR2
    Ac = Me2 + mR2 * np.cos(2 * phi).sum(axis=-1)
    As = mR2 * np.sin(2 * phi).sum(axis=-1)
    S2 = np.stack([I0 / 2, np.zeros(batch), np.zeros(batch), -Ac / 2, As / 2], axis=-1)
    C2 = np.stack([I0 / 2, np.zeros(batch), np.zeros(batch), Ac / 2, -As / 2], axis=-1)
    SC = np.stack([np.zeros(batch), np.zeros(batch), np.zeros(batch), As / 2, Ac / 2], axis=-1)
    Z, al, be = 0, 1, 2
    Mt = bc(p.M + p.M_P + n * p.m)
    Ba = bc(p.b ** 2 + 4 * p.d ** 2)
    A2 = bc(p.a ** 2)
    Jzw = bc(p.J_z) * w
    # Eq. (29) and the Z coupling of Eq. (30)
    for H, cZZ, cZa in ((Mh, Mt, -d * M_P), (Ch, 4 * c, -4 * d * c), (Kh, 4 * k, -4 * d * k)):
        H[..., 0, Z, Z] = cZZ
        H[..., 0, Z, al] = H[..., 0, al, Z] = cZa
    # Eq. (30)
    Mh[..., :, al, al] = S2
    Mh[..., 0, al, al] += bc(p.J_x + p.J_Px + p.M_P * p.d ** 2)
    Mh[..., :, al, be] = -SC
    Ch[..., :, al, al] = 2 * w[..., None] * SC
    Ch[..., 0, al, al] += Ba * c
    Ch[..., :, al, be] = 2 * w[..., None] * S2
    Ch[..., 0, al, be] += Jzw
    Kh[..., 0, al, al] = Ba * k
    # Eq. (31)
    Mh[..., :, be, be] = C2
    Mh[..., 0, be, be] += bc(p.J_y + p.J_Py)
    Mh[..., :, be, al] = -SC
    Ch[..., :, be, be] = -2 * w[..., None] * SC
    Ch[..., 0, be, be] += A2 * c
    Ch[..., :, be, al] = -2 * w[..., None] * C2
    Ch[..., 0, be, al] -= Jzw
    Kh[..., 0, be, be] = A2 * k
    return Mh, Ch, Kh


def _phi_star(params: DriveParams, phi_star):
    check_in_plane(params)
    return balanced_phi_star(params, phi_star)


def in_plane(params: DriveParams, omega: float, phi_star=None) -> PeriodicSystem:
    """Return M_I(t), C_I(t), K_I(t) of Eq. (35) at the balanced equilibrium (Eq. 26)."""
    phi = _phi_star(params, phi_star)
    M, C, K = in_plane_harmonics(params, omega, phi)
    coords = ('X', 'Y', 'gamma') + tuple(f'phi_{i + 1}' for i in range(params.n))
    return PeriodicSystem(M, C, K, float(omega), 2 * math.pi / omega if omega else math.inf,
                          coords)


def out_of_plane(params: DriveParams, omega: float, phi_star=None) -> PeriodicSystem:
    """Return M_O(t), C_O(t), K_O(t) of Eq. (37) at the balanced equilibrium (Eq. 26)."""
    phi = _phi_star(params, phi_star)
    M, C, K = out_of_plane_harmonics(params, omega, phi)
    return PeriodicSystem(M, C, K, float(omega), math.pi / omega if omega else math.inf,
                          ('Z', 'alpha', 'beta'))


def natural_frequencies(params: DriveParams) -> dict:
    """Return Section 4's undamped natural frequencies [rad/s] of Eqs. (27)-(32), m = omega = 0.

    Each mode is named after the coordinate with the largest share of its kinetic energy.
    Values for Table 1 (the paper's in brackets): X 299.5, Y 300.5, Z 299.1 (omega0 ~ 298),
    gamma 587.5 (577), alpha 543.2 (535), beta 774.3 (750). The gaps (0.5-3.2 %) are not a
    coupling that is left out: the d-coupling of X with gamma (Eqs. 27, 32) and of Z with alpha
    (Eqs. 29, 30) is kept, and it is what lifts gamma and alpha above their uncoupled values
    512 and 472 rad/s. Table 1 lists rounded values; the omega0 of Eq. (39) is
    sqrt(4k/(M+M_P)) = 300.5 rad/s (the paper's 298 implies ~1 % more mass or less stiffness).
    """
    check_in_plane(params)
    zero = SimpleNamespace(**{f: getattr(params, f) for f in _FIELDS})
    zero.m = 0.0
    out = {}
    for builder, names in ((in_plane_harmonics, ('X', 'Y', 'gamma')),
                           (out_of_plane_harmonics, ('Z', 'alpha', 'beta'))):
        Mh, _, Kh = builder(zero, 0.0, np.zeros(0))
        out.update(named_modes(_at_zero(Mh), _at_zero(Kh), names))
    return out


def named_modes(M, K, names) -> dict:
    """Return {name: undamped natural frequency [rad/s]} of M x'' + K x = 0.

    Each mode is named after the coordinate (of ``names``) with the largest share of its
    kinetic energy.
    """
    out = {}
    vals, vecs = scipy.linalg.eigh(K, M)
    for lam, v in zip(vals, vecs.T):
        share = v * (M @ v)  # kinetic-energy share of each coordinate
        out[names[int(np.argmax(np.abs(share)))]] = math.sqrt(max(lam, 0.0))
    return out


def _at_zero(H):
    """Return the 3x3 block of the coefficient matrix at tau = 0 (constant + cosine harmonics)."""
    return (H[0] + H[1::2].sum(axis=0))[:3, :3]


"""Monodromy matrices and Floquet multipliers of Eqs. (35) and (37), batched.

The linearised systems M(t) x'' + C(t) x' + K(t) x = 0 (:mod:`abb_ros.model.stability.linear`) have
coefficients periodic in tau = omega t. The fundamental matrix over one period (tau from 0 to
2 pi in-plane, pi out-of-plane) is integrated in tau, where the equation reads
``M x_tt + (C/omega) x_t + (K/omega^2) x = 0``, with classical RK4 at a fixed number of steps per
period chosen per point from its fastest rate (:func:`steps_for`). The coefficient matrices are
evaluated from their harmonics at the 2 N + 1 distinct stage times, and the state is kept in
second-order form Y = [Q; V] (Q' = V, V' = P Q + S V with P = -M^-1 K, S = -M^-1 C), so one step
costs two 'solve M' and four (nq x nq) by (nq x 2nq) products.

The kernel is built twice from one source (:mod:`abb_ros.model.jit`; ``JIT``: numba, parallel
over the points of the batch; ``PY``: the same statements in plain Python), and a test checks
the two agree. The multipliers are the eigenvalues of the monodromy matrix Phi(T); the point is
balanced and stable when the largest modulus is < 1 (Section 4).

Neutral directions of the balanced family. Where the balanced equilibria of Eq. (26) form a
family (n >= 3, or n = 2 at eps = 0; :mod:`abb_ros.model.stability.family`), each of its k tangent
directions V (ball angles in null J, deck and rates zero) is an equilibrium of the in-plane
linearisation, so Phi V = V: k multipliers exactly 1 whose rounding would decide
``|lambda|max < 1``. They are removed exactly: in the orthonormal basis T = [W V] (W the
complement of V) the monodromy is block triangular, T^T Phi T = [[C, 0], [B, I_k]], and the
*transverse* multipliers are the eigenvalues of C = W^T Phi W. The number removed (``neutral``)
and the self-check ``invariance`` = max over V's columns of ||Phi V - V|| (round-off, 1e-15,
when V is truly invariant) come with every result; above :data:`INVARIANCE_TOL` it is an
error (:class:`FamilyInvarianceError`), not a verdict. Where k = 0 (n = 2 with eps > 0, and
the out-of-plane equations, which have no ball coordinates) nothing changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from abb_ros.model.jit import Kernels, KernelSet, prange
from abb_ros.model.parameters.params import ParamError
from abb_ros.model.stability.equilibrium import (
    EQ26_TOL,
    balanced_equilibrium,
    ball_capacity,
    epsbar_lim,
    fan_phi_star,
    mbar_lim,
)
from abb_ros.model.stability.family import tangent_frame
from abb_ros.model.stability.linear import in_plane_harmonics, out_of_plane_harmonics, stack_params

__all__ = ['STEPS_PER_RADIAN', 'MIN_STEPS', 'MAX_STEPS', 'JIT', 'PY', 'SERIAL', 'monodromy_batch',
           'steps_for', 'monodromy', 'monodromy_reference', 'multipliers', 'max_multiplier',
           'PLANES',
           'equilibria', 'max_multiplier_batch', 'sweep_speed', 'PointStability',
           'point_stability', 'StabilityMap', 'stability_map', 'MAP_AXES', 'BALANCED', 'UNSTABLE',
           'NO_EQUILIBRIUM', 'INVARIANCE_TOL', 'FamilyInvarianceError', 'MultiplierBatch',
           'multipliers_batch', 'transverse_max_multiplier', 'member_extremes', 'MAX_MEMBERS']

STEPS_PER_RADIAN = 8.0
"""RK4 steps per radian of the fastest phase advance in tau (chosen in test_floquet's accuracy
study: |lambda|max within 1e-6 of a DOP853 reference at rtol 1e-12; the error falls as
STEPS_PER_RADIAN**-4, and 12 gave 3e-8 at worst on a random sample)."""

MAX_STEPS = 100_000
"""Most RK4 steps per period of one point (a few seconds of work): the steps follow from the
ratio of the drive's fastest natural rate to the spindle speed, so a speed far below the
resonances (0.01 rad/s) is refused before any work, naming the slowest speed that fits."""

MIN_STEPS = 32
"""Fewest RK4 steps per period."""


kernel = KernelSet()
"""Marks the kernels of this module (:mod:`abb_ros.model.jit`); the entry points add
nogil and fastmath, and parallel over the batch for monodromy_many."""


@kernel
def eval_coeffs(H, basis, out):
    """Set out = sum_j H[j] basis[j], basis = [1, cos tau, sin tau, cos 2 tau, sin 2 tau]."""
    nh, nq = H.shape[0], H.shape[1]
    for i in range(nq):
        for j in range(nq):
            acc = H[0, i, j]
            for h in range(1, nh):
                acc += basis[h] * H[h, i, j]
            out[i, j] = acc


@kernel
def accel_matrix(Mh, Ch, Kh, tau, Mw, R, basis):
    """Set R = -M(tau)^-1 [K(tau) C(tau)], shape (nq, 2 nq), by Gauss elimination (pivoting).

    Mw (nq, nq) and basis (5,) are work buffers.
    """
    nq = Mh.shape[1]
    basis[0] = 1.0
    basis[1] = math.cos(tau)
    basis[2] = math.sin(tau)
    basis[3] = math.cos(2.0 * tau)
    basis[4] = math.sin(2.0 * tau)
    eval_coeffs(Mh, basis, Mw)
    eval_coeffs(Kh, basis, R[:, :nq])
    eval_coeffs(Ch, basis, R[:, nq:])
    for i in range(nq):
        for j in range(2 * nq):
            R[i, j] = -R[i, j]
    for col in range(nq):
        piv = col
        big = abs(Mw[col, col])
        for r in range(col + 1, nq):
            if abs(Mw[r, col]) > big:
                big = abs(Mw[r, col])
                piv = r
        if piv != col:
            for j in range(nq):
                tmp = Mw[col, j]
                Mw[col, j] = Mw[piv, j]
                Mw[piv, j] = tmp
            for j in range(2 * nq):
                tmp = R[col, j]
                R[col, j] = R[piv, j]
                R[piv, j] = tmp
        inv = 1.0 / Mw[col, col]
        for r in range(col + 1, nq):
            f = Mw[r, col] * inv
            if f != 0.0:
                for j in range(col, nq):
                    Mw[r, j] -= f * Mw[col, j]
                for j in range(2 * nq):
                    R[r, j] -= f * R[col, j]
    for col in range(nq - 1, -1, -1):
        inv = 1.0 / Mw[col, col]
        for j in range(2 * nq):
            acc = R[col, j]
            for r in range(col + 1, nq):
                acc -= Mw[col, r] * R[r, j]
            R[col, j] = acc * inv

@kernel
def deriv(R, Q, V, dQ, dV):
    """Set dQ = V, dV = P Q + S V with R = [P S]; Q, V shape (nq, m)."""
    nq, m = Q.shape
    for i in range(nq):
        for j in range(m):
            dV[i, j] = 0.0
            dQ[i, j] = V[i, j]
        for k in range(nq):
            p = R[i, k]
            s = R[i, nq + k]
            for j in range(m):
                dV[i, j] += p * Q[k, j] + s * V[k, j]

@kernel
def axpy(Q, V, h, dQ, dV, Qo, Vo):
    nq, m = Q.shape
    for i in range(nq):
        for j in range(m):
            Qo[i, j] = Q[i, j] + h * dQ[i, j]
            Vo[i, j] = V[i, j] + h * dV[i, j]

@kernel(nogil=True, fastmath=True)
def monodromy_one(Mh, Ch, Kh, tau_end, nsteps, Phi):
    """Set Phi = the fundamental matrix at tau_end of M x'' + C x' + K x = 0 (tau units), RK4."""
    nq = Mh.shape[1]
    m = 2 * nq
    Q = np.zeros((nq, m))
    V = np.zeros((nq, m))
    for i in range(nq):
        Q[i, i] = 1.0
        V[i, nq + i] = 1.0
    Mw = np.empty((nq, nq))
    basis = np.empty(5)
    R0 = np.empty((nq, m))
    Rm = np.empty((nq, m))
    R1 = np.empty((nq, m))
    kQ = np.empty((4, nq, m))
    kV = np.empty((4, nq, m))
    Qt = np.empty((nq, m))
    Vt = np.empty((nq, m))
    h = tau_end / nsteps
    accel_matrix(Mh, Ch, Kh, 0.0, Mw, R0, basis)
    for step in range(nsteps):
        t0 = step * h
        accel_matrix(Mh, Ch, Kh, t0 + 0.5 * h, Mw, Rm, basis)
        accel_matrix(Mh, Ch, Kh, t0 + h, Mw, R1, basis)
        deriv(R0, Q, V, kQ[0], kV[0])
        axpy(Q, V, 0.5 * h, kQ[0], kV[0], Qt, Vt)
        deriv(Rm, Qt, Vt, kQ[1], kV[1])
        axpy(Q, V, 0.5 * h, kQ[1], kV[1], Qt, Vt)
        deriv(Rm, Qt, Vt, kQ[2], kV[2])
        axpy(Q, V, h, kQ[2], kV[2], Qt, Vt)
        deriv(R1, Qt, Vt, kQ[3], kV[3])
        w = h / 6.0
        for i in range(nq):
            for j in range(m):
                Q[i, j] += w * (kQ[0, i, j] + 2.0 * (kQ[1, i, j] + kQ[2, i, j]) + kQ[3, i, j])
                V[i, j] += w * (kV[0, i, j] + 2.0 * (kV[1, i, j] + kV[2, i, j]) + kV[3, i, j])
        for i in range(nq):
            for j in range(m):
                R0[i, j] = R1[i, j]
    for i in range(nq):
        for j in range(m):
            Phi[i, j] = Q[i, j]
            Phi[nq + i, j] = V[i, j]

@kernel(nogil=True, fastmath=True, parallel=True)
def monodromy_many(Mh, Ch, Kh, tau_end, nsteps, Phi):
    """Run monodromy_one for each point b of the batch (parallel over b)."""
    for b in prange(Mh.shape[0]):
        monodromy_one(Mh[b], Ch[b], Kh[b], tau_end[b], nsteps[b], Phi[b])


@kernel(nogil=True, fastmath=True)
def monodromy_many_serial(Mh, Ch, Kh, tau_end, nsteps, Phi):
    """Run monodromy_one for each point b of the batch, in order, in the calling thread."""
    for b in range(Mh.shape[0]):
        monodromy_one(Mh[b], Ch[b], Kh[b], tau_end[b], nsteps[b], Phi[b])


JIT, PY = kernel.build()
"""JIT: compiled kernels (numba, parallel over the batch), or the twin where numba is
unavailable; PY: the pure-Python twin (the same statements, interpreted)."""

SERIAL = Kernels({'monodromy_many': JIT.monodromy_many_serial,
                  'monodromy_one': JIT.monodromy_one}, compiled=JIT.compiled)
"""Compiled kernels that run the batch in one thread (for a process that is one worker of
many, e.g. a Dask worker of ``abb-sim sweep``); its cached build also loads in ~0.1 s where
the parallel one takes ~2 s."""


def steps_for(rate_tau, tau_end) -> np.ndarray:
    """Return the RK4 steps per period for each point's fastest rate [1/rad of tau] (int array)."""
    rate = np.asarray(rate_tau, dtype=float)
    return np.maximum(MIN_STEPS, np.ceil(STEPS_PER_RADIAN * rate * np.asarray(tau_end)))\
        .astype(np.int64)


def monodromy_batch(Mh, Ch, Kh, omega, tau_end, nsteps, kern=None) -> np.ndarray:
    """Compute the monodromy matrices in tau units for a batch.

    Mh, Ch, Kh : ndarray, shape (B, H, nq, nq), harmonics in SI (linear.py);
    omega : (B,) [rad/s]; tau_end : (B,) period in tau (2 pi or pi); nsteps : (B,) int.
    Returns Phi, shape (B, 2 nq, 2 nq), for the state [x, dx/dtau].
    """
    kern = kern or JIT
    omega = np.asarray(omega, dtype=float)
    Mh = np.ascontiguousarray(Mh, dtype=float)
    Ch = np.ascontiguousarray(Ch / omega[:, None, None, None])
    Kh = np.ascontiguousarray(Kh / (omega ** 2)[:, None, None, None])
    B, nq = Mh.shape[0], Mh.shape[2]
    Phi = np.zeros((B, 2 * nq, 2 * nq))
    kern.monodromy_many(Mh, Ch, Kh, np.broadcast_to(np.asarray(tau_end, float), (B,)).copy(),
                        np.broadcast_to(np.asarray(nsteps, np.int64), (B,)).copy(), Phi)
    return Phi


def multipliers(Phi) -> np.ndarray:
    """Return the Floquet multipliers, the eigenvalues of Phi, shape (..., 2 nq) complex."""
    return np.linalg.eigvals(Phi)


def max_multiplier(Phi) -> np.ndarray:
    """Return the largest |multiplier| of each monodromy matrix (shape Phi.shape[:-2])."""
    return np.abs(multipliers(Phi)).max(axis=-1)


INVARIANCE_TOL = 1e-9
"""Largest ||Phi V - V|| (V the family's orthonormal tangent directions) accepted as neutral.
Measured 2e-16 to 8e-16 (n = 2..10, wbar 0.7..2.7): it is the monodromy's round-off, so any
larger value means V is not an equilibrium direction of the linearisation (a wrong phi* or
a broken integration), which must not be read as a verdict."""


class FamilyInvarianceError(RuntimeError):
    """The family's tangent directions are not invariant under the monodromy (self-check)."""


def transverse_max_multiplier(Phi, U, k: int):
    """Return the largest |transverse multiplier| and invariance residual of each monodromy.

    Phi : (B, 2 nq, 2 nq) in-plane monodromies (state [X, Y, gamma, phi_1..phi_n, rates]);
    U, k : the ball-angle frames of :func:`abb_ros.model.stability.family.tangent_frame` (U (B, n,
    n), its last k columns the tangent directions), the same k for the batch. Returns
    (lam (B,), invariance (B,)); see the module docstring.
    """
    B, m = Phi.shape[0], Phi.shape[-1]
    n = U.shape[-1]
    T = np.broadcast_to(np.eye(m), (B, m, m)).copy()
    T[:, 3:3 + n, 3:3 + n] = U
    tangent = np.arange(3 + n - k, 3 + n)
    keep = np.setdiff1d(np.arange(m), tangent)
    V = T[:, :, tangent]
    invariance = np.linalg.norm(Phi @ V - V, axis=-2).max(axis=-1)
    C = (np.swapaxes(T, -1, -2) @ Phi @ T)[:, keep][:, :, keep]
    return max_multiplier(C), invariance


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


# ---- batched multipliers at balanced equilibria --------------------------------------------

PLANES = {'in': (in_plane_harmonics, 2 * math.pi), 'out': (out_of_plane_harmonics, math.pi)}
"""Builder of the harmonics and the period in tau of each plane (T_I = 2 pi/omega, T_O = T_I/2)."""

CHUNK = 2000
"""Points per kernel call (progress is reported per chunk)."""


def _rate_estimate(Mh, Ch, Kh, omega):
    """Estimate the fastest rate [1/rad of tau] of each point, from the constant harmonic, plus 1.

    sqrt of the largest eigenvalue of M0^-1 K0 / omega^2 (oscillation) plus the largest one of
    M0^-1 C0 / omega (decay); the +1 covers the phase advance of the rotating terms. A point
    whose matrices overflow (a speed near zero) has rate inf.
    """
    Minv = np.linalg.inv(Mh[:, 0])
    w = omega[:, None, None]
    with np.errstate(over='ignore', divide='ignore', invalid='ignore'):
        K, C = Minv @ Kh[:, 0] / w ** 2, Minv @ Ch[:, 0] / w
    rate = np.full(len(omega), np.inf)
    ok = np.isfinite(K).all(axis=(1, 2)) & np.isfinite(C).all(axis=(1, 2))
    if ok.any():
        osc = np.abs(np.linalg.eigvals(K[ok])).max(axis=-1)
        dec = np.abs(np.linalg.eigvals(C[ok])).max(axis=-1)
        rate[ok] = np.sqrt(osc) + dec + 1.0
    return rate


def _built(p, builder, omegas, phi, tau_end, sel):
    """Return the harmonics and the fastest rate (:func:`_rate_estimate`) of the points ``sel``."""
    sub = type(p)(**{f: v[sel] if isinstance(v, np.ndarray) else v for f, v in vars(p).items()})
    Mh, Ch, Kh = builder(sub, omegas[sel], phi[sel])
    return Mh, Ch, Kh, _rate_estimate(Mh, Ch, Kh, omegas[sel])


def _check_steps(p, builder, omegas, phi, tau_end, chunks):
    """Refuse, before any integration, a batch with a point needing over MAX_STEPS steps.

    Returns the harmonics and rates of a single chunk (so they are built once), else [].
    """
    worst, where, kept = 0.0, 0.0, []
    for sel in chunks:
        Mh, Ch, Kh, rate = _built(p, builder, omegas, phi, tau_end, sel)
        if len(chunks) == 1:
            kept = [(Mh, Ch, Kh, rate)]
        i = int(np.argmax(rate))
        if STEPS_PER_RADIAN * rate[i] * tau_end > worst:
            worst, where = STEPS_PER_RADIAN * float(rate[i]) * tau_end, float(omegas[sel][i])
    if worst > MAX_STEPS:
        slowest = where * worst / MAX_STEPS
        valid = f'at least about {slowest:.3g} rad/s for this drive' if math.isfinite(
            slowest) else 'a speed well above 0 rad/s'
        raise ParamError('omega', where, valid,
                         f'{worst:.3g} RK4 steps per period, over the limit of {MAX_STEPS}: '
                         'the drive\'s fastest rate (stiffness, damping) is far above the speed')
    return kept


def equilibria(params_list):
    """Find the balanced equilibria of a batch of DriveParams (same n).

    Returns (exists (B,), phi_star (B, n)).

    The symmetric fan where the imbalance is within the balls' capacity (equilibrium.py).
    """
    n = params_list[0].n
    p = stack_params(params_list)
    B = len(params_list)
    if n == 0:
        return p.eps == 0.0, np.zeros((B, 0))
    ratio = p.M * p.eps / (p.m * p.R)
    capacity = np.array([ball_capacity(q) for q in params_list])
    exists = ratio <= capacity if n > 1 else np.abs(ratio - 1.0) <= EQ26_TOL
    phi = np.zeros((B, n))
    if exists.any():
        phi[exists] = fan_phi_star(n, ratio[exists]) if n > 1 else math.pi
    return exists, phi


@dataclass(frozen=True)
class MultiplierBatch:
    """Largest |multiplier| of a batch of operating points (arrays of shape (B,)).

    ``lam``: the largest |transverse multiplier| (+inf where no balanced equilibrium exists);
    ``exists``; ``neutral``: the family's neutral multipliers removed (0 out-of-plane and for
    n = 2 with eps > 0); ``invariance``: ||Phi V - V|| of those directions (0 where none).
    """

    lam: np.ndarray
    exists: np.ndarray
    neutral: np.ndarray
    invariance: np.ndarray


def multipliers_batch(params_list, omegas, plane='in', phi_star=None, progress=None,
                      kern=None) -> MultiplierBatch:
    """Compute the largest |transverse Floquet multiplier| at the balanced equilibria of a batch.

    params_list : sequence of DriveParams with the same n; omegas : (B,) [rad/s] > 0;
    phi_star : optional (B, n) or (n,) [rad] members of the family, else the symmetric fan
    (equilibrium.py). ``progress(k)`` is called with the number of points done after each
    chunk. Raises :class:`FamilyInvarianceError` when a point fails the self-check.
    """
    builder, tau_end = PLANES[plane]
    omegas = np.asarray(omegas, dtype=float)
    if np.any(omegas <= 0):
        raise ParamError('omega', float(omegas.min()), '(0, inf) rad/s')
    B = len(params_list)
    if phi_star is None:
        exists, phi = equilibria(params_list)
    else:
        exists = np.ones(B, dtype=bool)
        phi = np.broadcast_to(np.asarray(phi_star, dtype=float), (B, params_list[0].n))
    lam = np.full(B, np.inf)
    neutral = np.zeros(B, dtype=np.int64)
    invariance = np.zeros(B)
    p = stack_params(params_list)
    idx = np.flatnonzero(exists)
    chunks = [idx[start:start + CHUNK] for start in range(0, idx.size, CHUNK)]
    built = _check_steps(p, builder, omegas, phi, tau_end, chunks)
    for sel in chunks:
        Mh, Ch, Kh, rate = built.pop(0) if built else _built(p, builder, omegas, phi, tau_end,
                                                               sel)
        steps = steps_for(rate, tau_end)
        Phi = monodromy_batch(Mh, Ch, Kh, omegas[sel], tau_end, steps, kern)
        if plane == 'in' and phi.shape[1] > 1:
            U, k = tangent_frame(phi[sel])
        else:
            U, k = None, np.zeros(sel.size, dtype=np.int64)
        plain = k == 0
        lam[sel[plain]] = max_multiplier(Phi[plain])
        for count in np.unique(k[k > 0]):
            group = np.flatnonzero(k == count)
            lam[sel[group]], invariance[sel[group]] = transverse_max_multiplier(
                Phi[group], U[group], int(count))
        neutral[sel] = k
        if progress is not None:
            progress(sel.size)
    if progress is not None and idx.size < B:
        progress(B - idx.size)
    bad = np.flatnonzero(invariance > INVARIANCE_TOL)
    if bad.size:
        i = int(bad[np.argmax(invariance[bad])])
        raise FamilyInvarianceError(
            f'the balanced family\'s tangent directions are not neutral at omega = '
            f'{omegas[i]:.6g} rad/s (||Phi V - V|| = {invariance[i]:.3g} > {INVARIANCE_TOL:g}): '
            'no stability verdict')
    return MultiplierBatch(lam, exists, neutral, invariance)


def max_multiplier_batch(params_list, omegas, plane='in', phi_star=None, progress=None,
                         kern=None):
    """Return (lam (B,), exists (B,) bool) of :func:`multipliers_batch`.

    ``lam`` is the largest |transverse Floquet multiplier| at the balanced equilibrium (+inf
    where none exists).
    """
    res = multipliers_batch(params_list, omegas, plane, phi_star, progress, kern)
    return res.lam, res.exists


MAX_MEMBERS = 64
"""Most members of the family sampled per point by :func:`member_extremes`."""


def member_extremes(params_list, omegas, plane='in', count=8, progress=None, kern=None,
                    fan_lam=None):
    """Compute the best and worst |lambda|max over sampled members of each point's balanced family.

    For n >= 3 the balanced equilibria form a family, and stability may differ along it:
    this answers "can these balls balance here at all" (best) and "do they balance wherever
    they settle" (worst). Each point's members are its symmetric fan and count - 1 random
    members (:func:`abb_ros.model.stability.family.sample_members`, seeded, balls kept the contact
    separation apart when they touch); points sharing M eps / (m R) share members. n <= 2
    has the fan only (its mirror image has the same multipliers). ``fan_lam`` (B,): the fan's
    |lambda|max when the caller has it (a map), else it is computed. Returns (best (B,),
    worst (B,), sampled (B,) int: members evaluated per point); +inf where no balanced
    equilibrium exists.
    """
    from abb_ros.model.stability.equilibrium import least_spacing
    from abb_ros.model.stability.family import sample_members
    if not 1 <= count <= MAX_MEMBERS:
        raise ParamError('members', count, f'[1, {MAX_MEMBERS}]')
    omegas = np.asarray(omegas, dtype=float)
    n = params_list[0].n
    if fan_lam is None:
        fan_lam, exists = max_multiplier_batch(params_list, omegas, plane, kern=kern)
    else:
        exists, _ = equilibria(params_list)
    best, worst = np.array(fan_lam, dtype=float), np.array(fan_lam, dtype=float)
    sampled = exists.astype(np.int64)
    cache, rows, owner = {}, [], []
    for i in np.flatnonzero(exists) if n >= 3 else ():
        p = params_list[i]
        key = (p.M * p.eps / (p.m * p.R), least_spacing(p))
        if key not in cache:
            cache[key] = sample_members(*key[:1], n, count - 1, spacing=key[1])
        rows.append(cache[key])
        owner.append(np.full(len(cache[key]), i))
        sampled[i] += len(cache[key])
    if rows and sum(len(r) for r in rows):
        phi = np.concatenate(rows)
        who = np.concatenate(owner)
        per = max(float(sampled[exists].mean()) - 1.0, 1.0)
        res = multipliers_batch([params_list[i] for i in who], omegas[who], plane, phi,
                                None if progress is None else (lambda k: progress(k / per)),
                                kern)
        np.minimum.at(best, who, res.lam)
        np.maximum.at(worst, who, res.lam)
    elif progress is not None:
        progress(int(exists.sum()))
    if progress is not None and not exists.all():
        progress(int((~exists).sum()))
    return best, worst, sampled


def sweep_speed(params, omegas, plane='in', phi_star=None) -> np.ndarray:
    """Compute |lambda|max against spindle speed omegas [rad/s] for fixed parameters.

    +inf at every speed when no balanced equilibrium exists. About 0.2 s for 200 speeds once
    the kernel is compiled (numba caches it on disk; the first use in a fresh checkout compiles
    for ~20 s).
    """
    omegas = np.atleast_1d(np.asarray(omegas, dtype=float))
    lam, _ = max_multiplier_batch([params] * omegas.size, omegas, plane, phi_star)
    return lam


# ---- one operating point and two-parameter maps ----------------------------------------------

MAP_AXES = ('wbar', 'zeta', 'Dbar', 'epsbar', 'mbar')
"""Parameters a stability map may vary (Eq. 39)."""

BALANCED, UNSTABLE, NO_EQUILIBRIUM = 0, 1, 2
"""Map status codes: balanced and stable (|lambda|max < 1); balanced equilibrium unstable;
no balanced equilibrium (n m R < M eps). Both of the last two are 'unbalanced'."""


@dataclass(frozen=True)
class PointStability:
    """Stability of the balanced equilibrium at one operating point (Section 4).

    ``lam_in``/``lam_out``: largest |transverse multiplier| per plane; ``neutral``: the
    family's neutral in-plane multipliers removed; ``invariance``: their self-check
    ||Phi V - V||; ``member``: which equilibrium of the family was evaluated.
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
        planes = [name for name, lam in (('in-plane', self.lam_in), ('out-of-plane', self.lam_out))
                  if lam >= 1.0]
        return 'unbalanced (' + ' and '.join(planes) + ' unstable)'


def point_stability(params, omega, phi_star=None, member=None) -> PointStability:
    """Compute in-plane and out-of-plane |lambda|max at the balanced equilibrium.

    ``phi_star`` : a member of the family [rad] (checked against Eq. 26), default the
    symmetric fan; ``member`` names it in the result (default 'symmetric fan' or 'given').
    """
    eq = balanced_equilibrium(params, phi_star)
    name = member or ('symmetric fan' if phi_star is None else 'given')
    if not eq.exists:
        return PointStability(float(omega), False, eq.phi_star, math.inf, math.inf, eq.reason,
                              member=name)
    res = {plane: multipliers_batch([params], [omega], plane, eq.phi_star)
           for plane in ('in', 'out')}
    return PointStability(float(omega), True, eq.phi_star, float(res['in'].lam[0]),
                          float(res['out'].lam[0]), neutral=int(res['in'].neutral[0]),
                          invariance=float(res['in'].invariance[0]), member=name)


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


def stability_map(base, x, x_values, y, y_values, settings=None, plane='in',
                  progress=None, members=0) -> StabilityMap:
    """Compute |lambda|max over the grid x_values x y_values of two Eq. (39) parameters.

    base : DriveParams; settings : further fixed settings for apply_settings (e.g. zeta, wbar);
    every point is converted with :func:`abb_ros.model.parameters.params.apply_settings`. wbar must
    be one of the axes or in ``settings``.
    """
    from abb_ros.model.parameters.params import apply_settings
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
    xs = np.asarray(x_values, dtype=float)
    ys = np.asarray(y_values, dtype=float)
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
    omegas = np.asarray(omegas)
    lam, exists = max_multiplier_batch(plist, np.maximum(omegas, 1e-9), plane,
                                       progress=progress)
    status = np.where(~exists, NO_EQUILIBRIUM, np.where(lam < 1.0, BALANCED, UNSTABLE))
    first = plist[0]
    fixed = {'settings': settings, 'n': first.n, 'omega0': first.omega0,
             **{k: v for k, v in first.dimensionless().items() if k not in (x, y)},
             'SI': {k: v for k, v in first.as_dict().items()}}
    limits = {}
    if y == 'mbar' or x == 'mbar':
        limits['mbar_lim'] = mbar_lim(first)
    if y == 'epsbar' or x == 'epsbar':
        limits['epsbar_lim'] = epsbar_lim(first)
    shape = (ys.size, xs.size)
    smap = StabilityMap(x, y, xs, ys, lam.reshape(shape), status.reshape(shape), plane, fixed,
                        limits)
    if members:
        best, worst, sampled = member_extremes(plist, np.maximum(omegas, 1e-9), plane, members,
                                               progress, fan_lam=lam)
        smap.lam_best, smap.lam_worst = best.reshape(shape), worst.reshape(shape)
        smap.members = int(sampled[exists].min()) if exists.any() else 0
    return smap

"""Largest Floquet multipliers at the balanced equilibria of batches of operating points.

For each point the harmonics of Eq. (35) or (37) are built at its balanced equilibrium
(:mod:`abb_ros.model.stability.linear`), the monodromy is integrated by
:mod:`abb_ros.model.stability.monodromy`, and the multipliers are the eigenvalues of the
monodromy matrix Phi(T); the point is balanced and stable when the largest modulus is < 1
(Section 4).

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

from abb_ros.model.parameters.params import ParamError
from abb_ros.model.stability import floquet_reduction as reduction
from abb_ros.model.stability.equilibrium import EQ26_TOL, ball_capacity, fan_phi_star
from abb_ros.model.stability.family import tangent_frame
from abb_ros.model.stability.linear import in_plane_harmonics, out_of_plane_harmonics, stack_params
from abb_ros.model.stability.monodromy import (
    MAX_STEPS,
    STEPS_PER_RADIAN,
    monodromy_batch,
    steps_for,
)

__all__ = ['multipliers', 'max_multiplier', 'PLANES', 'equilibria', 'max_multiplier_batch',
           'sweep_speed', 'INVARIANCE_TOL', 'FamilyInvarianceError', 'MultiplierBatch',
           'multipliers_batch', 'transverse_max_multiplier', 'member_extremes', 'MAX_MEMBERS',
           'rate_estimate', 'refuse_over_step_limit']

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


def transverse_max_multiplier(Phi, U, k: int, first_ball: int = 3):
    """Return the largest |transverse multiplier| and invariance residual of each monodromy.

    Phi : (B, 2 nq, 2 nq) in-plane monodromies (state [X, Y, gamma, phi_1..phi_n, rates]);
    U, k : the ball-angle frames of :func:`abb_ros.model.stability.family.tangent_frame` (U (B, n,
    n), its last k columns the tangent directions), the same k for the batch. Returns
    (lam (B,), invariance (B,)); see the module docstring.
    """
    B, m = Phi.shape[0], Phi.shape[-1]
    n = U.shape[-1]
    T = np.broadcast_to(np.eye(m), (B, m, m)).copy()
    b = first_ball
    T[:, b:b + n, b:b + n] = U
    tangent = np.arange(b + n - k, b + n)
    keep = np.setdiff1d(np.arange(m), tangent)
    V = T[:, :, tangent]
    invariance = np.linalg.norm(Phi @ V - V, axis=-2).max(axis=-1)
    C = (np.swapaxes(T, -1, -2) @ Phi @ T)[:, keep][:, :, keep]
    return max_multiplier(C), invariance


PLANES = {'in': (in_plane_harmonics, 2 * math.pi), 'out': (out_of_plane_harmonics, math.pi)}
"""Builder of the harmonics and the period in tau of each plane (T_I = 2 pi/omega, T_O = T_I/2)."""

CHUNK = 2000
"""Points per kernel call (progress is reported per chunk)."""


def rate_estimate(Mh, Ch, Kh, omega, decay_floor=0.0):
    """Estimate the fastest rate [1/rad of tau] of each point, from the constant harmonic, plus 1.

    sqrt of the largest eigenvalue of M0^-1 K0 / omega^2 (oscillation) plus the largest one of
    M0^-1 C0 / omega (decay, at least ``decay_floor``: the decay of the directions a reduced
    system leaves out); the +1 covers the phase advance of the rotating terms. A point whose
    matrices overflow (a speed near zero) has rate inf.
    """
    Minv = np.linalg.inv(Mh[:, 0])
    w = omega[:, None, None]
    with np.errstate(over='ignore', divide='ignore', invalid='ignore'):
        K, C = Minv @ Kh[:, 0] / w ** 2, Minv @ Ch[:, 0] / w
    rate = np.full(len(omega), np.inf)
    ok = np.isfinite(K).all(axis=(1, 2)) & np.isfinite(C).all(axis=(1, 2))
    if ok.any():
        osc = np.abs(np.linalg.eigvals(K[ok])).max(axis=-1)
        dec = np.maximum(np.abs(np.linalg.eigvals(C[ok])).max(axis=-1),
                         np.broadcast_to(decay_floor, rate.shape)[ok])
        rate[ok] = np.sqrt(osc) + dec + 1.0
    return rate


@dataclass
class _Chunk:
    """The harmonics of a chunk of points and their fastest rates.

    ``Q`` (B, n, 3): the ball basis of the reduced in-plane system
    (:mod:`abb_ros.model.stability.floquet_reduction`), None when the system is the whole
    one; ``decay`` (B,): then the decoupled directions' decay per radian of tau.
    """

    Mh: np.ndarray
    Ch: np.ndarray
    Kh: np.ndarray
    rate: np.ndarray
    Q: np.ndarray | None = None
    decay: np.ndarray | None = None


def _built(p, builder, omegas, phi, sel, reduce=True):
    """Return the :class:`_Chunk` of the points ``sel`` (reduced in-plane where n > 3)."""
    sub = type(p)(**{f: v[sel] if isinstance(v, np.ndarray) else v for f, v in vars(p).items()})
    Mh, Ch, Kh = builder(sub, omegas[sel], phi[sel])
    if not (reduce and builder is in_plane_harmonics and reduction.reduces(phi.shape[1])):
        return _Chunk(Mh, Ch, Kh, rate_estimate(Mh, Ch, Kh, omegas[sel]))
    Q = reduction.ball_basis(phi[sel])
    Mh, Ch, Kh = reduction.project(Mh, Ch, Kh, Q)
    decay = reduction.complement_decay(sub, omegas[sel])
    return _Chunk(Mh, Ch, Kh, rate_estimate(Mh, Ch, Kh, omegas[sel], decay), Q, decay)


def _check_steps(p, builder, omegas, phi, tau_end, chunks, reduce=True):
    """Refuse, before any integration, a batch with a point needing over MAX_STEPS steps.

    Returns the :class:`_Chunk` of a single chunk in a list (so it is built once), else [].
    """
    worst, where, kept = 0.0, 0.0, []
    for sel in chunks:
        chunk = _built(p, builder, omegas, phi, sel, reduce)
        rate = chunk.rate
        if len(chunks) == 1:
            kept = [chunk]
        i = int(np.argmax(rate))
        if STEPS_PER_RADIAN * rate[i] * tau_end > worst:
            worst, where = STEPS_PER_RADIAN * float(rate[i]) * tau_end, float(omegas[sel][i])
    refuse_over_step_limit(worst, where)
    return kept


def refuse_over_step_limit(worst: float, where: float) -> None:
    """Refuse a speed whose period needs more than MAX_STEPS RK4 steps (ParamError: omega).

    ``worst`` steps per period at ``where`` rad/s; the message names the slowest speed that fits.
    """
    if worst > MAX_STEPS:
        slowest = where * worst / MAX_STEPS
        valid = f'at least about {slowest:.3g} rad/s for this drive' if math.isfinite(
            slowest) else 'a speed well above 0 rad/s'
        raise ParamError('omega', where, valid,
                         f'{worst:.3g} RK4 steps per period, over the limit of {MAX_STEPS}: '
                         'the drive\'s fastest rate (stiffness, damping) is far above the speed')


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


def _neutral_frame(chunk, phi, plane):
    """Return (U, k): the basis of the family's neutral directions and their count per point.

    The reduced frame where the chunk is reduced (``chunk.Q``), the family's tangent frame in
    plane with more than one ball, else none (U None, k 0).
    """
    if chunk.Q is not None:
        return reduction.reduced_frame(phi, chunk.Q)
    if plane == 'in' and phi.shape[1] > 1:
        return tangent_frame(phi)
    return None, np.zeros(phi.shape[0], dtype=np.int64)


def multipliers_batch(params_list, omegas, plane='in', phi_star=None, progress=None,
                      kern=None, reduce=True) -> MultiplierBatch:
    """Compute the largest |transverse Floquet multiplier| at the balanced equilibria of a batch.

    params_list : sequence of DriveParams with the same n; omegas : (B,) [rad/s] > 0;
    phi_star : optional (B, n) or (n,) [rad] members of the family, else the symmetric fan
    (equilibrium.py). ``progress(k)`` is called with the number of points done after each
    chunk. Raises :class:`FamilyInvarianceError` when a point fails the self-check.
    ``reduce``: integrate the in-plane system of n > 3 balls reduced to six coordinates
    (:mod:`abb_ros.model.stability.floquet_reduction`; the same multipliers to round-off); False
    integrates all 3 + n.
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
    built = _check_steps(p, builder, omegas, phi, tau_end, chunks, reduce)
    for sel in chunks:
        chunk = built.pop(0) if built else _built(p, builder, omegas, phi, sel, reduce)
        steps = steps_for(chunk.rate, tau_end)
        Phi = monodromy_batch(chunk.Mh, chunk.Ch, chunk.Kh, omegas[sel], tau_end, steps, kern)
        U, k = _neutral_frame(chunk, phi[sel], plane)
        plain = k == 0
        lam[sel[plain]] = max_multiplier(Phi[plain])
        for count in np.unique(k[k > 0]):
            group = np.flatnonzero(k == count)
            lam[sel[group]], invariance[sel[group]] = transverse_max_multiplier(
                Phi[group], U[group], int(count))
        if chunk.Q is not None:
            decoupled = phi.shape[1] - chunk.Q.shape[-1]
            k = k + decoupled
            lam[sel] = np.maximum(lam[sel], reduction.complement_multiplier(
                chunk.decay, tau_end, steps))
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


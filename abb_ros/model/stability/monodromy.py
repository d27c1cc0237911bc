"""Monodromy matrices of the periodic systems of Eqs. (35) and (37): the compiled RK4 kernels.

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
the two agree. The multipliers built on it are in :mod:`abb_ros.model.stability.floquet_batch`.
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.jit import Kernels, KernelSet, prange

__all__ = ['STEPS_PER_RADIAN', 'MIN_STEPS', 'MAX_STEPS', 'JIT', 'PY', 'SERIAL', 'monodromy_batch',
           'steps_for']

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
    eliminate(Mw, R)
    back_substitute(Mw, R)


@kernel
def eliminate(Mw, R):
    """Reduce Mw to upper triangular form, rows of R alike (partial pivoting), in place."""
    nq = Mw.shape[0]
    for col in range(nq):
        piv = col
        big = abs(Mw[col, col])
        for r in range(col + 1, nq):
            if abs(Mw[r, col]) > big:
                big = abs(Mw[r, col])
                piv = r
        if piv != col:
            swap_rows(Mw, R, col, piv)
        inv = 1.0 / Mw[col, col]
        for r in range(col + 1, nq):
            f = Mw[r, col] * inv
            if f != 0.0:
                for j in range(col, nq):
                    Mw[r, j] -= f * Mw[col, j]
                for j in range(R.shape[1]):
                    R[r, j] -= f * R[col, j]


@kernel
def swap_rows(Mw, R, a, b):
    """Swap rows a and b of Mw and of R."""
    for j in range(Mw.shape[1]):
        tmp = Mw[a, j]
        Mw[a, j] = Mw[b, j]
        Mw[b, j] = tmp
    for j in range(R.shape[1]):
        tmp = R[a, j]
        R[a, j] = R[b, j]
        R[b, j] = tmp


@kernel
def back_substitute(Mw, R):
    """Set R = Mw^-1 R for an upper triangular Mw, in place."""
    nq = Mw.shape[0]
    for col in range(nq - 1, -1, -1):
        inv = 1.0 / Mw[col, col]
        for j in range(R.shape[1]):
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

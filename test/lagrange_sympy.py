"""Independent sympy derivation of the 3D equations of motion from the energies (Eqs. 1-17).

Kim, Lee & Chung, J. Sound Vib. 285 (2005) 547-569, Section 2, with the spindle angle
theta(t) in place of omega t (theta is the rotor angle relative to the deck; it is prescribed,
so it has no equation of its own, but theta'' may be non-zero).

Everything is built from inertial vectors (so T is frame-independent), without the small-angle
assumption: the expressions returned by :func:`lagrange_expressions` are Lagrange's equation (17)
EXACT in all coordinates. :func:`first_order` expands them to first order in the deck coordinates
X, Y, Z, alpha, beta, gamma (and their rates and accelerations), keeping theta and phi_i exact,
which is the approximation of the paper's Eqs. (18)-(24). :func:`paper_equations` is a
transcription of the printed Eqs. (18)-(24) (typos resolved, see docs/equations.md), written once
for sympy and numpy.

Coordinates: q = [theta, X, Y, Z, alpha, beta, gamma, phi_1..phi_n] (N = 7 + n), the abb_ros
state convention; the equations are returned in the order [X, Y, Z, alpha, beta, gamma,
phi_1..phi_n], each as d/dt dT/dq' - dT/dq + dV/dq + dF/dq'.

The numeric function is generated from the sympy expressions (common subexpressions eliminated),
its Python source cached in the temp directory keyed by n and a hash of this file, and loaded with
exec (math and cmath versions): a cold derivation takes ~20 s for n = 2, a warm load ~0.1 s.
The first-order residual is evaluated from the exact one by a complex-step derivative in the
deck scale (exact to round-off), so no second derivation is needed.

Run ``python test/lagrange_sympy.py [n]`` to print the first-order equations (the form to compare
with the printed Eqs. 18-24 term by term) and their theta'' terms.
"""

from __future__ import annotations

import cmath
import functools
import hashlib
import math
import os
import tempfile

import numpy as np
import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

PARAM_NAMES = ('a', 'b', 'd', 'R', 'M_P', 'M', 'm', 'J_Px', 'J_Py', 'J_Pz', 'J_x', 'J_y', 'J_z',
               'k', 'c', 'D', 'eps')
BEYOND_NAMES = ('r_ball', 'contact_E', 'contact_nu', 'contact_damping', 'ball_rotation')
"""Terms beyond the paper: ball radius, Hertzian contact, rolling-ball spin.

docs/ball_size_contact_rolling.md states them.
"""
HEIGHT_NAMES = ('z_P', 'z_G', 'z_B')
"""Heights of P, G and the race above the washers' plane (docs/equations.md, F4; 0: the paper)."""
TILT_NAMES = ('tau', 'psi_tau')
"""The rotor's principal axis leaning by tau toward psi_tau from G (docs/equations.md, F6)."""
DECK_NAMES = ('X', 'Y', 'Z', 'alpha', 'beta', 'gamma')

_SOURCE_HASH = hashlib.sha1(open(__file__, 'rb').read()).hexdigest()[:12]
CACHE_DIR = os.path.join(tempfile.gettempdir(), 'abb_ros_lagrange_sympy')


def coord_names(n):
    """theta, X, Y, Z, alpha, beta, gamma, phi_1..phi_n."""
    return ('theta',) + DECK_NAMES + tuple(f'phi_{i + 1}' for i in range(n))


@functools.lru_cache(maxsize=None)
def symbols(n):
    """(q, qd, qdd, params): sympy symbols for coordinates, rates, accelerations, parameters."""
    names = coord_names(n)
    q = sp.symbols(names, real=True)
    qd = sp.symbols([s + '_d' for s in names], real=True)
    qdd = sp.symbols([s + '_dd' for s in names], real=True)
    par = {p: sp.Symbol(p, positive=True) for p in PARAM_NAMES + BEYOND_NAMES}
    par.update({p: sp.Symbol(p, real=True) for p in HEIGHT_NAMES + TILT_NAMES})
    return tuple(q), tuple(qd), tuple(qdd), par


def euler_matrix(alpha, beta, gamma, lib=sp):
    """T_beta T_alpha T_gamma of Eqs. (1)-(2): inertial components -> deck (xyz) components."""
    ca, sa, cb, sb, cg, sg = (lib.cos(alpha), lib.sin(alpha), lib.cos(beta), lib.sin(beta),
                              lib.cos(gamma), lib.sin(gamma))
    T_gamma = sp.Matrix([[cg, sg, 0], [-sg, cg, 0], [0, 0, 1]])
    T_alpha = sp.Matrix([[1, 0, 0], [0, ca, sa], [0, -sa, ca]])
    T_beta = sp.Matrix([[cb, 0, -sb], [0, 1, 0], [sb, 0, cb]])
    return T_beta * T_alpha * T_gamma


def deck_angular_velocity(alpha, beta, gamma,  # noqa: ARG001 (the Euler triple, Eqs. 1-2)
                          alpha_d, beta_d, gamma_d):
    """omega_P in deck components, Eq. (10)."""
    return sp.Matrix([alpha_d * sp.cos(beta) - gamma_d * sp.cos(alpha) * sp.sin(beta),
                      beta_d + gamma_d * sp.sin(alpha),
                      alpha_d * sp.sin(beta) + gamma_d * sp.cos(alpha) * sp.cos(beta)])


def time_derivative(expr, q, qd, qdd):
    """d/dt of an expression in (q, q') by the chain rule (q, q' are symbols)."""
    return (sum(sp.diff(expr, qj) * vj for qj, vj in zip(q, qd))
            + sum(sp.diff(expr, vj) * aj for vj, aj in zip(qd, qdd)))


def corner_offsets(par):
    """r_CDi of Eq. (15) (deck components) = r_ODi (inertial components), i = 1..4."""
    a, b, d = par['a'], par['b'], par['d']
    return [sp.Matrix([a / 2, b / 2 - d, 0]), sp.Matrix([-a / 2, b / 2 - d, 0]),
            sp.Matrix([-a / 2, -(b / 2 + d), 0]), sp.Matrix([a / 2, -(b / 2 + d), 0])]


def rotor_inertia(par, tilt):
    """J_G in rotor-fixed axes: diag(J_x, J_y, J_z), or with ``tilt`` R^T diag R exactly.

    R^T = Q, the rotation by tau about (-sin psi_tau, cos psi_tau, 0), which takes the spin
    axis e_z to n = (sin tau cos psi_tau, sin tau sin psi_tau, cos tau): the principal axis
    leans by tau toward psi_tau from G's direction (the rotor's x axis).
    """
    J = sp.diag(par['J_x'], par['J_y'], par['J_z'])
    if not tilt:
        return J
    tau, psi = par['tau'], par['psi_tau']
    u = sp.Matrix([-sp.sin(psi), sp.cos(psi), 0])
    ux = sp.Matrix([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    Q = sp.eye(3) * sp.cos(tau) + ux * sp.sin(tau) + (1 - sp.cos(tau)) * u * u.T
    return Q * J * Q.T


@functools.lru_cache(maxsize=None)
def energies(n, beyond=False, tilt=False):
    """(T, V, F) of Eqs. (11), (13), (16) as sympy expressions in q, q' (exact, no small angles).

    Positions are inertial: body vector p -> (T_beta T_alpha T_gamma)^T p, C at (X, Y, Z).
    ``beyond``: add the ball-size, contact and spin terms (:func:`beyond_energies`); 'spin':
    only the rolling balls' spin energy. ``tilt``: the rotor's leaning principal axis
    (:func:`rotor_inertia`).
    """
    q, qd, _, par = symbols(n)
    theta, X, Y, Z, alpha, beta, gamma = q[:7]
    phis = q[7:]
    A_T = euler_matrix(alpha, beta, gamma).T            # deck -> inertial
    r_C = sp.Matrix([X, Y, Z])

    def velocity(r):
        return sp.Matrix([sum(sp.diff(ri, qj) * vj for qj, vj in zip(q, qd)) for ri in r])

    def kinetic(mass, r):
        v = velocity(r)
        return mass * v.dot(v) / 2

    eps, R, d = par['eps'], par['R'], par['d']
    r_G = r_C + A_T * sp.Matrix([eps * sp.cos(theta), eps * sp.sin(theta), par['z_G']])
    r_P = r_C + A_T * sp.Matrix([0, -d, par['z_P']])
    w_P = deck_angular_velocity(alpha, beta, gamma, *qd[4:7])        # Eq. (10)
    w_G = w_P + sp.Matrix([0, 0, qd[0]])                              # Eq. (9), omega -> theta'
    # J_G is diagonal in the spinning rotor: rotor components = R_z(theta)^T deck components.
    ct, st = sp.cos(theta), sp.sin(theta)
    w_rotor = sp.Matrix([[ct, st, 0], [-st, ct, 0], [0, 0, 1]]) * w_G
    T = (kinetic(par['M'], r_G) + kinetic(par['M_P'], r_P)
         + (w_rotor.T * rotor_inertia(par, tilt) * w_rotor)[0, 0] / 2
         + (par['J_Px'] * w_P[0] ** 2 + par['J_Py'] * w_P[1] ** 2 + par['J_Pz'] * w_P[2] ** 2) / 2)
    for phi in phis:
        r_B = r_C + A_T * sp.Matrix([R * sp.cos(phi + theta), R * sp.sin(phi + theta),
                                     par['z_B']])
        T += kinetic(par['m'], r_B)
    V = 0
    F = 0
    for off in corner_offsets(par):
        r_D = r_C + A_T * off - off                                   # Eq. (14), inertial
        V += par['k'] * r_D.dot(r_D) / 2                              # Eq. (13)
        v_D = velocity(r_D)
        F += par['c'] * v_D.dot(v_D) / 2                              # Eq. (16)
    F += par['D'] * sum(v ** 2 for v in qd[7:]) / 2
    if beyond:
        dT, dV, dF = beyond_energies(n)
        if beyond == 'spin':           # the rolling balls' spin only (no contact terms)
            dV = dF = 0
        T, V, F = T + dT, V + dV, F + dF
    return T, V, F


def contact_overlaps(n):
    """Overlap delta = 2 r - 2 R sin((phi_j - phi_i)/2) of every pair i < j, with its rate;
    valid for 0 < phi_j - phi_i < pi (the ordering the numeric checks use)."""
    q, qd, qdd, par = symbols(n)
    out = []
    for i in range(n):
        for j in range(i + 1, n):
            delta = 2 * par['r_ball'] - 2 * par['R'] * sp.sin((q[7 + j] - q[7 + i]) / 2)
            out.append((delta, time_derivative(delta, q, qd, qdd)))
    return out


def beyond_energies(n):
    """Return the ball-size, contact and spin additions (dT, dV, dF), exact.

    dT: each ball rolls on the race (contact at radius R + r): its angular velocity is the deck's
    (Eq. 10) plus (theta' - (R/r) phi_i') about the deck z axis; a sphere's inertia is isotropic,
    so T_spin = 1/2 J_b |omega|^2, J_b = ball_rotation 2/5 m r^2.
    dV: Hertz, 2/5 K delta^(5/2) per overlapping pair, K = 4/3 E/(2 (1 - nu^2)) sqrt(r/2).
    dF: Hunt-Crossley, 1/2 chi K delta^(3/2) delta'^2 per overlapping pair.
    Every pair is taken as overlapping (evaluate only where they all are).
    """
    q, qd, _, par = symbols(n)
    r, R = par['r_ball'], par['R']
    w_P = deck_angular_velocity(*q[4:7], *qd[4:7])
    Jb = par['ball_rotation'] * sp.Rational(2, 5) * par['m'] * r ** 2
    dT = 0
    for i in range(n):
        w = w_P + sp.Matrix([0, 0, qd[0] - R / r * qd[7 + i]])
        dT += Jb * w.dot(w) / 2
    nu = par['contact_nu']
    K = sp.Rational(4, 3) * par['contact_E'] / (2 * (1 - nu ** 2)) * sp.sqrt(r / 2)
    dV = 0
    dF = 0
    for delta, rate in contact_overlaps(n):
        dV += sp.Rational(2, 5) * K * delta ** sp.Rational(5, 2)
        dF += par['contact_damping'] * K * delta ** sp.Rational(3, 2) * rate ** 2 / 2
    return dT, dV, dF


@functools.lru_cache(maxsize=None)
def lagrange_expressions(n, beyond=False, theta_row=False, tilt=False):
    """Lagrange's Eq. (17) for X, Y, Z, alpha, beta, gamma, phi_i: list of 6 + n expressions.

    ``theta_row``: prepend theta's row, the torque the spindle motor must apply to impose
    theta(t) (its input power is theta' times it).
    """
    q, qd, qdd, _ = symbols(n)
    T, V, F = energies(n, beyond, tilt)
    out = []
    for k in range(0 if theta_row else 1, len(q)):
        p_k = sp.diff(T, qd[k])
        out.append(time_derivative(p_k, q, qd, qdd) - sp.diff(T, q[k])
                   + sp.diff(V, q[k]) + sp.diff(F, qd[k]))
    return out


def deck_scaling(n, s):
    """Substitution {x: s x} for the deck coordinates, their rates and accelerations."""
    q, qd, qdd, _ = symbols(n)
    return {v[i]: s * v[i] for v in (q, qd, qdd) for i in range(1, 7)}


@functools.lru_cache(maxsize=None)
def first_order(n, beyond=False):
    """Lagrange's equations to first order in the deck coordinates (theta, phi_i exact).

    E(s) with every deck quantity scaled by s; returns E(0) + E'(0), each term simplified.
    """
    s = sp.Symbol('s_scale')
    sub = deck_scaling(n, s)
    out = []
    for e in lagrange_expressions(n, beyond):
        es = e.xreplace(sub)
        e0 = es.xreplace({s: 0})
        e1 = sp.diff(es, s).xreplace({s: 0})
        out.append(sp.expand(e0 + e1))
    return out


def paper_equations(p, q, qd, qdd, lib=np):
    """Eqs. (18)-(24) as printed, LHS - RHS, with omega t -> theta and omega -> theta'.

    ``p`` maps parameter names to values (numbers or symbols); ``q, qd, qdd`` are sequences in
    the order [theta, X, Y, Z, alpha, beta, gamma, phi_1..phi_n]; ``lib`` is numpy or sympy.
    theta'' does not appear (the paper's omega is constant). Typos resolved: 'Mpd' = M_P d;
    returns a list of 6 + n residuals in the order X, Y, Z, alpha, beta, gamma, phi_i.
    """
    sin, cos = lib.sin, lib.cos
    a, b, d, R = p['a'], p['b'], p['d'], p['R']
    M_P, M, m = p['M_P'], p['M'], p['m']
    k, c, D, eps = p['k'], p['c'], p['D'], p['eps']
    th, X, Y, Z, al, be, ga = q[:7]
    w, Xd, Yd, Zd, ald, bed, gad = qd[:7]
    Xdd, Ydd, Zdd, aldd, bedd, gadd = qdd[1:7]
    phi, phid, phidd = q[7:], qd[7:], qdd[7:]
    n = len(phi)
    st, ct = sin(th), cos(th)
    si = [sin(phi[i] + th) for i in range(n)]
    ci = [cos(phi[i] + th) for i in range(n)]
    wi = [phid[i] + w for i in range(n)]
    mtot = M + M_P + n * m
    eq18 = (mtot * Xdd + 4 * c * Xd + 4 * k * X + (M_P * d - M * eps * st) * gadd
            + (4 * d * c - 2 * M * eps * w * ct) * gad + (4 * d * k + M * eps * w ** 2 * st) * ga
            - m * R * sum((gadd + phidd[i] - wi[i] ** 2 * ga) * si[i]
                          + (ga * phidd[i] + wi[i] * (2 * gad + wi[i])) * ci[i] for i in range(n))
            - M * eps * w ** 2 * ct)
    eq19 = (mtot * Ydd + 4 * c * Yd + 4 * k * Y + M * eps * ct * gadd
            - 2 * M * eps * w * st * gad - M * eps * w ** 2 * ct * ga
            + m * R * sum((gadd + phidd[i] - wi[i] ** 2 * ga) * ci[i]
                          - (ga * phidd[i] + wi[i] * (2 * gad + wi[i])) * si[i] for i in range(n))
            - M * eps * w ** 2 * st)
    eq20 = (mtot * Zdd + 4 * c * Zd + 4 * k * Z - (M_P * d - M * eps * st) * aldd
            - (4 * d * c - 2 * M * eps * w * ct) * ald - 4 * d * k * al
            - M * eps * bedd * ct + 2 * M * eps * w * bed * st
            + m * R * sum((-bedd + al * phidd[i] + 2 * wi[i] * ald + wi[i] ** 2 * be) * ci[i]
                          + (aldd + be * phidd[i] + 2 * wi[i] * bed - wi[i] ** 2 * al) * si[i]
                          for i in range(n))
            - M * eps * w ** 2 * (al * st - be * ct))
    mR2 = m * R ** 2
    ss = sum(si[i] ** 2 for i in range(n))
    cc = sum(ci[i] ** 2 for i in range(n))
    sc = sum(si[i] * ci[i] for i in range(n))
    wss = sum(wi[i] * si[i] ** 2 for i in range(n))
    wcc = sum(wi[i] * ci[i] ** 2 for i in range(n))
    wsc = sum(wi[i] * si[i] * ci[i] for i in range(n))
    Ssum = sum(si)
    Csum = sum(ci)
    eq21 = ((p['J_x'] + p['J_Px'] + M_P * d ** 2 + M * eps ** 2 * st ** 2 + mR2 * ss) * aldd
            + ((b ** 2 + 4 * d ** 2) * c + 2 * M * eps ** 2 * w * st * ct + 2 * mR2 * wsc) * ald
            + (b ** 2 + 4 * d ** 2) * k * al - (M * eps ** 2 * st * ct + mR2 * sc) * bedd
            + (p['J_z'] * w + 2 * M * eps ** 2 * w * st ** 2 + 2 * mR2 * wss) * bed
            + mR2 * be * sum(phidd)
            + (-M_P * d + M * eps * st + m * R * Ssum) * Zdd - 4 * d * c * Zd - 4 * d * k * Z)
    eq22 = ((p['J_y'] + p['J_Py'] + M * eps ** 2 * ct ** 2 + mR2 * cc) * bedd
            + (a ** 2 * c - 2 * M * eps ** 2 * w * st * ct - 2 * mR2 * wsc) * bed + a ** 2 * k * be
            - (M * eps ** 2 * st * ct + mR2 * sc) * aldd
            - (p['J_z'] * w + 2 * M * eps ** 2 * w * ct ** 2 + 2 * mR2 * wcc) * ald
            - (M * eps * ct + m * R * Csum) * Zdd)
    abd = a ** 2 + b ** 2 + 4 * d ** 2
    eq23 = ((p['J_z'] + p['J_Pz'] + M_P * d ** 2 + M * eps ** 2 + n * mR2) * gadd
            + abd * c * gad + abd * k * ga
            + (M_P * d - M * eps * st - m * R * Ssum) * Xdd + 4 * d * c * Xd + 4 * d * k * X
            + (M * eps * ct + m * R * Csum) * Ydd + mR2 * sum(phidd))
    eq24 = [mR2 * (gadd + phidd[i]) + D * phid[i] - m * R * (Xdd * si[i] - Ydd * ci[i])
            for i in range(n)]
    return [eq18, eq19, eq20, eq21, eq22, eq23] + eq24


# ---- numeric functions -------------------------------------------------------------------------

def _function_source(name, exprs, args):
    """Python source of ``name(q, qd, qdd, P)`` returning the list of exprs (CSE applied)."""
    printer = PythonCodePrinter({'fully_qualified_modules': False})
    repl, reduced = sp.cse(exprs, symbols=sp.numbered_symbols('_x'))
    q, qd, qdd, par = args
    lines = [f'def {name}(q, qd, qdd, P):']
    for group, vec in ((q, 'q'), (qd, 'qd'), (qdd, 'qdd')):
        lines.append('    ' + ', '.join(str(v) for v in group) + f', = {vec}')
    lines.append('    ' + ', '.join(PARAM_NAMES + BEYOND_NAMES + HEIGHT_NAMES + TILT_NAMES)
                 + ', = P')
    for sym, e in repl:
        lines.append(f'    {sym} = {printer.doprint(e)}')
    lines.append('    return [' + ', '.join(printer.doprint(e) for e in reduced) + ']')
    return '\n'.join(lines) + '\n'


def _load(name, n, build):
    """Source of ``name`` for n balls from the cache, building and caching it if absent."""
    path = os.path.join(CACHE_DIR, f'{name}_n{n}_{_SOURCE_HASH}.py')
    try:
        with open(path, encoding='utf-8') as f:
            return f.read(), path
    except OSError:
        pass
    src = build()
    os.makedirs(CACHE_DIR, exist_ok=True)
    tmp = f'{path}.{os.getpid()}.tmp'
    with open(tmp, 'w', encoding='utf-8') as f:
        f.write(src)
    os.replace(tmp, path)        # atomic: concurrent runs never read a half-written file
    return src, path


@functools.lru_cache(maxsize=None)
def compiled_lagrange(n, beyond=False, tilt=False):
    """(real, complex) numeric versions of :func:`lagrange_expressions` for n balls."""
    name = {False: 'lagrange', True: 'lagrange_beyond', 'spin': 'lagrange_spin'}[beyond]
    name += '_tilt' if tilt else ''
    src, path = _load(name, n, lambda: _function_source(
        name, lagrange_expressions(n, beyond, tilt=tilt), symbols(n)))
    return _exec(src, path, name, (math, cmath))


def _exec(src, path, name, libs):
    code = compile(src, path, 'exec')
    out = []
    for lib in libs:
        namespace = {'sin': lib.sin, 'cos': lib.cos, 'sqrt': lib.sqrt}
        exec(code, namespace)
        out.append(namespace[name])
    return tuple(out)


@functools.lru_cache(maxsize=None)
def compiled_energy_terms(n):
    """numpy function (q, qd, qdd, P) -> [T, V, F, tau], exact, with the rolling balls' spin
    energy (the contact's potential and damping come from the kernels, being pairwise and
    piecewise): the energies and theta's row of Lagrange's equations (the spindle torque),
    vectorised over arrays of states (the energy bookkeeping of
    docs/ball_size_contact_rolling.md)."""
    def build():
        q, qd, qdd, _ = symbols(n)
        T, V, F = energies(n)
        T += beyond_energies(n)[0]          # spin of rolling balls; contact: from the kernels
        tau = (time_derivative(sp.diff(T, qd[0]), q, qd, qdd) - sp.diff(T, q[0])
               + sp.diff(V, q[0]) + sp.diff(F, qd[0]))
        return _function_source('energy_terms', [T, V, F, tau], symbols(n))
    src, path = _load('energy_terms', n, build)
    return _exec(src, path, 'energy_terms', (np,))[0]


def _pack(params):
    return tuple(float(getattr(params, p))
                 for p in PARAM_NAMES + BEYOND_NAMES + HEIGHT_NAMES + TILT_NAMES)


def exact_residual(params, y, qdd, beyond=None):
    """Lagrange's Eq. (17) from the energies, exact, shape (6 + n,).

    Same API as ``abb_ros.model.dynamics.equations.lagrange_residual``: y = [q, q'] (2N,), qdd (N,)
    with theta'' at index 0; order [X, Y, Z, alpha, beta, gamma, phi_1..phi_n].
    """
    n = params.n
    N = 7 + n
    y = [float(v) for v in y]
    f = compiled_lagrange(n, bool(params.beyond_paper) if beyond is None else beyond,
                          params.tau != 0.0)[0]
    return np.array(f(y[:N], y[N:], [float(v) for v in qdd], _pack(params)))


COMPLEX_STEP = 1e-30
"""Step of the complex-step derivative: no subtraction, so any tiny step is exact to round-off."""


def first_order_residual(params, y, qdd, beyond=None):
    """Lagrange's equations to first order in the deck coordinates, theta and phi_i exact.

    E(0) + E'(0), where E(s) has X, Y, Z, alpha, beta, gamma and their rates and accelerations
    scaled by s; E'(0) by the complex step Im E(i h) / h, exact to round-off.
    """
    n = params.n
    N = 7 + n
    f = compiled_lagrange(n, bool(params.beyond_paper) if beyond is None else beyond,
                          params.tau != 0.0)[1]
    deck = np.zeros(N, dtype=bool)
    deck[1:7] = True
    y = np.asarray(y, dtype=float)
    q, qd, qdd = y[:N], y[N:], np.asarray(qdd, dtype=float)
    P = _pack(params)

    def at(scale):
        return [complex(v) for v in np.where(deck, scale * q, q)], \
            [complex(v) for v in np.where(deck, scale * qd, qd)], \
            [complex(v) for v in np.where(deck, scale * qdd, qdd)]

    e0 = np.array(f(*at(0.0), P)).real
    e1 = np.array(f(*at(1j * COMPLEX_STEP), P)).imag / COMPLEX_STEP
    return e0 + e1


@functools.lru_cache(maxsize=None)
def theta_expression(n):
    """Lagrange's equation for a FREE theta (torque mode): d/dt dT/dtheta' - dT/dtheta +
    dV/dtheta + dF/dtheta', exact; it equals the generalised force Q_theta of the motor."""
    q, qd, qdd, _ = symbols(n)
    T, V, F = energies(n)
    return (time_derivative(sp.diff(T, qd[0]), q, qd, qdd) - sp.diff(T, q[0])
            + sp.diff(V, q[0]) + sp.diff(F, qd[0]))


@functools.lru_cache(maxsize=None)
def compiled_theta(n):
    """Complex-valued numeric :func:`theta_expression` (a one-element list) for n balls."""
    src, path = _load('lagrange_theta', n, lambda: _function_source(
        'lagrange_theta', [theta_expression(n)], symbols(n)))
    namespace = {'sin': cmath.sin, 'cos': cmath.cos, 'sqrt': cmath.sqrt}
    exec(compile(src, path, 'exec'), namespace)
    return namespace['lagrange_theta']


def theta_residuals(params, y, qdd):
    """(exact, first order) of :func:`theta_expression` at (y, qdd), like
    :func:`exact_residual` and :func:`first_order_residual`."""
    n = params.n
    N = 7 + n
    f = compiled_theta(n)
    deck = np.zeros(N, dtype=bool)
    deck[1:7] = True
    y = np.asarray(y, dtype=float)
    q, qd, qdd = y[:N], y[N:], np.asarray(qdd, dtype=float)
    P = _pack(params)

    def at(scale):
        return ([complex(v) for v in np.where(deck, scale * x, x)] for x in (q, qd, qdd))

    exact = f(*at(1.0), P)[0].real
    first = f(*at(0.0), P)[0].real + f(*at(1j * COMPLEX_STEP), P)[0].imag / COMPLEX_STEP
    return exact, first


def paper_residual(params, y, qdd):
    """Eqs. (18)-(24) as printed (theta'' ignored), numpy, same API as lagrange_residual."""
    n = params.n
    N = 7 + n
    y = np.asarray(y, dtype=float)
    return np.array(paper_equations(params.as_dict(), y[:N], y[N:], np.asarray(qdd, float)))


def report(n=2):
    """Print, per equation: first-order expansion minus printed equation (theta'' = 0 part), and
    the coefficient of theta'' (first order), both simplified."""
    q, qd, qdd, par = symbols(n)
    paper = paper_equations(par, q, qd, qdd, lib=sp)
    names = DECK_NAMES + tuple(f'phi_{i + 1}' for i in range(n))
    for name, e, pe in zip(names, first_order(n), paper):
        diff = sp.expand(sp.expand_trig(e - pe))
        thdd = diff.coeff(qdd[0])
        rest = sp.simplify(sp.expand(diff - thdd * qdd[0]))
        print(f'[{name}] first order - printed (theta\'\' = 0): {rest}')
        print(f'[{name}] theta\'\' coefficient: {sp.factor_terms(sp.simplify(thdd))}')
    print()
    for name, e in zip(names, first_order(n)):
        print(f'[{name}] first order = {sp.collect(e, qdd + qd)}\n')


if __name__ == '__main__':
    import sys
    report(int(sys.argv[1]) if len(sys.argv) > 1 else 2)

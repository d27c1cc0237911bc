"""Compiled kernels of the nonlinear model, each with a pure-Python twin.

One source, two builds (:mod:`abb_ros.model.jit`): the functions below are plain Python,
marked as kernels; ``JIT`` holds them compiled with numba (cached on disk) and ``PY`` as they
are (plain Python on numpy arrays). Both run the same statements, so they agree to round-off
(``test_kernels`` checks it); ``PY`` is the fallback where numba is unavailable (set
``ABB_ROS_NO_JIT=1`` to force it).

Packed inputs (plain float arrays, so the kernels stay free of Python objects):

``P`` : ndarray, shape (N_PARAMS,)
    Drive parameters in the order of :data:`PARAM_ORDER` (SI).
``S`` : ndarray, shape (N_SPINDLE,)
    Spindle profile: ``[mode, omega_cmd, max_accel, tau, t0, t1, ramp_accel]`` with mode
    0 = constant speed (theta'' = 0, the paper's case), 1 = motor tracking omega_cmd as a
    first-order lag of time constant tau limited to +-max_accel, 2 = ramp: theta'' =
    ramp_accel for t0 <= t < t1, else 0. Mode 3 = torque (theta free, docs/torque_mode.md):
    ``[3, i_cmd, K_t, R_w, I_max, b_v, T_c, omega_c, V_s]`` (N_SPINDLE_TORQUE values), the
    current command and the motor of :func:`motor_current` and :func:`spindle_torque`.

State ``y = [q, q']`` with ``q = [theta, X, Y, Z, alpha, beta, gamma, phi_1..phi_n]``: the
kernels index it with the offsets of :mod:`abb_ros.model.state` (DECK, PHI; N = PHI + n).
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.jit import KernelSet
from abb_ros.model.state import DECK, PHI, THETA

PARAM_ORDER = ('a', 'b', 'd', 'R', 'M_P', 'M', 'm', 'J_Px', 'J_Py', 'J_Pz', 'J_x', 'J_y', 'J_z',
               'k', 'c', 'D', 'eps', 'n',
               'r_ball', 'contact_E', 'contact_nu', 'contact_damping', 'rolling_mu',
               'rolling_stick_rate', 'ball_rotation')
N_PARAMS = len(PARAM_ORDER)
N_SPINDLE = 7
SPINDLE_CONSTANT, SPINDLE_MOTOR, SPINDLE_RAMP = 0, 1, 2
SPINDLE_TORQUE = 3
N_SPINDLE_TORQUE = 9

# Envelope of sane states; outside it the small-angle model is meaningless and the
# integration stops (docs/architecture.md, Errors). Deck translations in m, angles in rad,
# rates in rad/s.
MAX_TRANSLATION = 0.02
MAX_ANGLE = 0.3
MAX_BALL_RATE = 1.0e5

OK, NONFINITE, ENVELOPE = 0, 1, 2

# Beyond the paper (issue 12, docs/beyond_the_paper.md): indices into P, and constants.
I_R_BALL, I_CONTACT_E, I_CONTACT_NU, I_CONTACT_DAMPING = 18, 19, 20, 21
I_ROLLING_MU, I_STICK_RATE, I_BALL_ROTATION = 22, 23, 24
SPIN_INERTIA = 0.4
"""J_b = 2/5 m r_ball^2 of a solid sphere."""
STICK_TIME = 1.0e-3
"""A stuck ball's residual rate phi_i' (inside the stick band) decays with this time [s]."""
CONTACT_OMEGA_H = 0.3
"""Largest omega_c h of the stiffest contact per RK4 (sub)step during an impact."""
CONTACT_IMPACT_SPEED = 0.128
"""Impacts slower than this [m/s] are resolved to an absolute rather than a relative accuracy
(:func:`impact_relaxation`): at CONTACT_OMEGA_H / MIS_IMPACT_REFINE RK4 returns a Hertz
impact's rebound speed to 7.8e-5 of it at worst (measured over the phases of the contact's
onset on the sub-step grid), i.e. to 1e-5 m/s at this speed."""
CONTACT_ERROR_ORDER = 2.7
"""That rebound error grows as (omega_c h)^2.7 (measured from omega_c h = 0.1 to 0.8: the
onset of a Hertz contact is not smooth, so RK4 is not of order 4 there)."""
CONTACT_RELAX_MAX = 3.0
"""A slow impact's omega_c h is at most this many times an impact's (where the error law was
measured)."""
CONTACT_OMEGA_H_REST = 2.0
"""Largest omega_c h of a resting contact (its present overlap exceeds the impact overlap of
its approach speed): below RK4's stability limit 2.78, its unresolved contact vibration is
damped numerically, the static compression is exact."""
CONTACT_REST_IMBALANCE = 0.25
"""A pair taken for resting did not rest over a step when its rate changed by more than this
fraction of what its contact force alone, unbalanced, would change it by over the step
(:func:`resting_misjudged`): a resting contact's force is carried by the load that presses the
balls together (~0), an impact's by nothing (~1)."""
MAX_SUBSTEPS = 4096
MAX_SWITCHES = 16
"""Most rolling-regime switches located within one RK4 (sub)step (the rest of the step then
keeps the regimes it has)."""
SWITCH_TOL = 1.0e-12
"""A switching instant is located to this fraction of the (sub)step at worst ..."""
MARGIN_TOL = 1.0e-9
"""... or to a state past it whose switching function (dimensionless) is above -MARGIN_TOL
(the band's margin changes at ~1 / STICK_TIME: ~1e-12 s)."""
MAX_LOCATE = 60
"""Most regula-falsi iterations per switching instant."""
MIS_A = np.array([[0.0, 0.0, 0.0], [1.0 / 3.0, 0.0, 0.0], [-3.0 / 16.0, 15.0 / 16.0, 0.0],
                  [1.0 / 6.0, 3.0 / 10.0, 8.0 / 15.0]])
"""Knoth & Wolke's third-order three-stage RK (rows 0-2: a_ij, row 3: b_j), the slow method of
the multirate contact step (:func:`mis_contact_step`; MIS: Wensch, Knoth, Galant 2009)."""
MIS_C = np.array([0.0, 1.0 / 3.0, 3.0 / 4.0, 1.0])
"""Its stage times c_i, and 1."""
MIS_APART_MARGIN = 2.0
"""The multirate step's fast sub-steps are merged into one only while every pair of balls
stays apart for this many times their length at its present closing rate
(:func:`apart_substeps`)."""
MIS_IMPACT_REFINE = 1.5
"""The multirate step's fast sub-steps per contact sub-step in an impact (rounded up): the
impact's resolution is its largest error (energy closure of test_beyond_energy's collision
without rolling: 1.0e-6 with 1, 5.3e-7 with 1.5, 5.2e-7 with 2, 3.9e-7 with 4; RK4 sub-steps
of the whole system: 1.5e-7, docs/beyond_the_paper.md)."""



kernel = KernelSet(nogil=True, error_model='numpy')
"""Marks the kernels of this module (compiled where numba is available)."""


@kernel
def spindle_accel(t, omega, S):
    """theta'' of the spindle profile S at time t and speed omega [rad/s^2]."""
    mode = S[0]
    if mode == SPINDLE_MOTOR:
        acc = (S[1] - omega) / S[3]
        if acc > S[2]:
            acc = S[2]
        elif acc < -S[2]:
            acc = -S[2]
        return acc
    if mode == SPINDLE_RAMP:
        if S[4] <= t < S[5]:
            return S[6]
        return 0.0
    return 0.0

@kernel
def assemble(y, n, P, thdd, A, W, f, B, fb):
    """Eqs. (18)-(24) generalised to theta(t): the (6+n) system before elimination.

    Deck rows (X, Y, Z, alpha, beta, gamma): A @ u + W @ phi'' = f, with u the deck
    accelerations; ball rows: B @ u + m R^2 phi'' = fb. The rotor's mass centre G is
    treated like a ball of mass M at radius eps and angle theta whose angle has a known
    second derivative theta''; every phi_i'' of the paper is the ball's acceleration
    relative to the rotor, and the inertial angle psi_i = phi_i + theta has psi_i'' =
    phi_i'' + theta''.
    """
    a, b, d, R = P[0], P[1], P[2], P[3]
    M_P, M, m = P[4], P[5], P[6]
    J_Px, J_Py, J_Pz, J_x, J_y, J_z = P[7], P[8], P[9], P[10], P[11], P[12]
    k, c, D, eps = P[13], P[14], P[15], P[16]
    N = PHI + n
    X, Y, Z, al, be, ga = (y[DECK], y[DECK + 1], y[DECK + 2], y[DECK + 3], y[DECK + 4],
                           y[DECK + 5])
    om = y[N + THETA]
    Xd, Yd, Zd, ald, bed, gad = (y[N + DECK], y[N + DECK + 1], y[N + DECK + 2],
                                 y[N + DECK + 3], y[N + DECK + 4], y[N + DECK + 5])
    Mt = M + M_P + n * m

    # Sums over the rotating point masses j = G (M, eps, theta) and balls (m, R, phi_i + theta),
    # with the known part psi'' = theta'' of their angular accelerations.
    S1 = 0.0   # sum mu r sin(psi)
    C1 = 0.0   # sum mu r cos(psi)
    Sss = 0.0  # sum mu r^2 sin^2
    Scc = 0.0  # sum mu r^2 cos^2
    Ssc = 0.0  # sum mu r^2 sin cos
    Wsc = 0.0  # sum mu r^2 psi' sin cos
    Wss = 0.0  # sum mu r^2 psi' sin^2
    Wcc = 0.0  # sum mu r^2 psi' cos^2
    FX = 0.0   # known inertial terms moved to the right of the X, Y, Z rows
    FY = 0.0
    FZ = 0.0
    for j in range(n + 1):
        if j == 0:
            mu = M
            r = eps
            psi = y[THETA]
            psid = om
        else:
            mu = m
            r = R
            psi = y[THETA] + y[PHI - 1 + j]
            psid = om + y[N + PHI - 1 + j]
        s = math.sin(psi)
        co = math.cos(psi)
        mr = mu * r
        mr2 = mr * r
        S1 += mr * s
        C1 += mr * co
        Sss += mr2 * s * s
        Scc += mr2 * co * co
        Ssc += mr2 * s * co
        Wsc += mr2 * psid * s * co
        Wss += mr2 * psid * s * s
        Wcc += mr2 * psid * co * co
        # Eq. (18): -mu r {[g'' + psi'' - psi'^2 g] sin + [g psi'' + psi'(2 g' + psi')] cos}
        tX = (thdd - psid * psid * ga) * s + (ga * thdd + psid * (2.0 * gad + psid)) * co
        # Eq. (19): +mu r {[g'' + psi'' - psi'^2 g] cos - [g psi'' + psi'(2 g' + psi')] sin}
        tY = (thdd - psid * psid * ga) * co - (ga * thdd + psid * (2.0 * gad + psid)) * s
        # Eq. (20): +mu r {[-b'' + a psi'' + 2 psi' a' + psi'^2 b] cos
        #                  + [a'' + b psi'' + 2 psi' b' - psi'^2 a] sin}
        tZ = ((al * thdd + 2.0 * psid * ald + psid * psid * be) * co
              + (be * thdd + 2.0 * psid * bed - psid * psid * al) * s)
        FX += mr * tX
        FY -= mr * tY
        FZ -= mr * tZ
        if j > 0:
            # ball i = j - 1: its accelerations' coefficients in the deck rows, and Eq. (24)
            i = j - 1
            W[0, i] = -mr * (s + ga * co)
            W[1, i] = mr * (co - ga * s)
            W[2, i] = mr * (al * co + be * s)
            W[3, i] = mr2 * be
            W[4, i] = 0.0
            W[5, i] = mr2
            B[i, 0] = -mr * s
            B[i, 1] = mr * co
            B[i, 2] = 0.0
            B[i, 3] = 0.0
            B[i, 4] = 0.0
            B[i, 5] = mr2
            fb[i] = -D * y[N + PHI + i] - mr2 * thdd
    Ir = M * eps * eps + n * m * R * R
    kb = b * b + 4.0 * d * d
    kab = a * a + b * b + 4.0 * d * d

    for i in range(6):
        for j in range(6):
            A[i, j] = 0.0
    if P[I_CONTACT_E] > 0.0 and n > 1:
        Qc = np.empty(n)
        contact_forces(y, n, P, Qc)
        for i in range(n):
            fb[i] += Qc[i]
    # Eq. (18), X
    A[0, 0] = Mt
    A[0, 5] = M_P * d - S1
    f[0] = -4.0 * c * Xd - 4.0 * k * X - 4.0 * d * c * gad - 4.0 * d * k * ga + FX
    # Eq. (19), Y
    A[1, 1] = Mt
    A[1, 5] = C1
    f[1] = -4.0 * c * Yd - 4.0 * k * Y + FY
    # Eq. (20), Z
    A[2, 2] = Mt
    A[2, 3] = -M_P * d + S1
    A[2, 4] = -C1
    f[2] = -4.0 * c * Zd - 4.0 * k * Z + 4.0 * d * c * ald + 4.0 * d * k * al + FZ
    # Eq. (21), alpha
    A[3, 3] = J_x + J_Px + M_P * d * d + Sss
    A[3, 4] = -Ssc
    A[3, 2] = -M_P * d + S1
    f[3] = (-(kb * c + 2.0 * Wsc) * ald - kb * k * al - (J_z * om + 2.0 * Wss) * bed
            + 4.0 * d * c * Zd + 4.0 * d * k * Z - be * (Ir + J_z) * thdd)
    # Eq. (22), beta
    A[4, 4] = J_y + J_Py + Scc
    A[4, 3] = -Ssc
    A[4, 2] = -C1
    f[4] = -(a * a * c - 2.0 * Wsc) * bed - a * a * k * be + (J_z * om + 2.0 * Wcc) * ald
    # Eq. (23), gamma
    A[5, 5] = J_z + J_Pz + M_P * d * d + Ir
    A[5, 0] = M_P * d - S1
    A[5, 1] = C1
    f[5] = (-kab * (c * gad + k * ga) - 4.0 * d * c * Xd - 4.0 * d * k * X
            - (Ir + J_z) * thdd)
    if P[I_BALL_ROTATION] != 0.0:
        add_ball_rotation(y, n, P, thdd, A, W, f, B, fb)

@kernel
def add_ball_rotation(y, n, P, thdd, A, W, f, B, fb):
    """Rolling balls' spin inertia J_b = 2/5 m r^2 (issue 12), first order in the deck.

    A ball rolling on the race (contact at radius R + r) spins at Omega = theta' + gamma'
    + alpha' beta - (R / r) phi_i' about z, plus the deck's alpha', beta'; its kinetic
    energy 1/2 J_b |omega|^2 adds J_b (R/r)^2 = 2/5 m R^2 to the ball row's phi_i'' (7/5 in
    all), J_b R/r = 2/5 m R r to the gamma'' and theta'' couplings, J_b to the deck's
    rotational inertias and the spin terms J_b Omega beta', -J_b Omega alpha' (like J_z).
    """
    N = PHI + n
    R, m, r = P[3], P[6], P[I_R_BALL]
    Jb = SPIN_INERTIA * m * r * r
    JbRr = SPIN_INERTIA * m * R * r          # J_b R / r
    be = y[5]
    ald, bed = y[N + 4], y[N + 5]
    om = y[N]
    spin = 0.0                               # sum J_b (theta' - R/r phi_i')
    for i in range(n):
        spin += Jb * om - JbRr * y[N + PHI + i]
        W[3, i] -= JbRr * be
        W[5, i] -= JbRr
        B[i, 5] -= JbRr
        fb[i] += JbRr * thdd
    A[3, 3] += n * Jb
    A[4, 4] += n * Jb
    A[5, 5] += n * Jb
    f[3] -= n * Jb * thdd * be + spin * bed
    f[4] += spin * ald
    f[5] -= n * Jb * thdd

@kernel
def contact_stiffness(P):
    """K of the Hertzian law F = K delta^1.5 between two equal balls of radius r:
    K = 4/3 E* sqrt(r/2), E* = E / (2 (1 - nu^2)) [N/m^1.5]."""
    r, E, nu = P[I_R_BALL], P[I_CONTACT_E], P[I_CONTACT_NU]
    return 4.0 / 3.0 * E / (2.0 * (1.0 - nu * nu)) * math.sqrt(0.5 * r)

@kernel
def near(dphi, reach):
    """True when the angle dphi, wrapped to [-pi, pi), is shorter than reach (a cheap test
    before :func:`pair_state`)."""
    dphi -= 2.0 * math.pi * math.floor(dphi / (2.0 * math.pi) + 0.5)
    return abs(dphi) < reach

@kernel
def pair_state(y, n, P, i, j):
    """(overlap delta, its rate delta', lever) of balls i < j: centres 2 R |sin(dphi/2)|
    apart (dphi = phi_j - phi_i wrapped to [-pi, pi)); delta = 2 r - distance; lever =
    d distance / d phi_j = R cos(dphi/2) sign(dphi) = -d distance / d phi_i."""
    N = PHI + n
    R, r = P[3], P[I_R_BALL]
    dphi = y[PHI + j] - y[PHI + i]
    dphi -= 2.0 * math.pi * math.floor(dphi / (2.0 * math.pi) + 0.5)
    half = 0.5 * dphi
    lever = R * math.cos(half)
    if dphi < 0.0:
        lever = -lever
    delta = 2.0 * r - 2.0 * R * abs(math.sin(half))
    rate = -lever * (y[N + PHI + j] - y[N + PHI + i])
    return delta, rate, lever

@kernel
def contact_forces(y, n, P, Qc):
    """Generalized forces Qc (one per ball row) of the ball-ball contacts (issue 12).

    Hunt-Crossley: F = K delta^1.5 (1 + chi delta') >= 0 along the line of centres, from the
    potential 2/5 K delta^2.5 and the dissipation 1/2 chi K delta^1.5 delta'^2; on ball j
    Q_j = F lever, on ball i the opposite (internal: no force on the deck or the rotor).
    Returns (contact potential energy [J], contact damping power [W]).
    """
    K = contact_stiffness(P)
    chi = P[I_CONTACT_DAMPING]
    sep = 2.0 * math.asin(P[I_R_BALL] / P[3])
    for i in range(n):
        Qc[i] = 0.0
    energy = 0.0
    power = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            e, p = add_pair_force(y, n, P, K, chi, sep, i, j, Qc)
            energy += e
            power += p
    return energy, -power

@kernel
def add_pair_force(y, n, P, K, chi, sep, i, j, Qc):
    """Adds the Hunt-Crossley force of the pair (i, j) to Qc (:func:`contact_forces`);
    returns its (potential energy, elastic minus total power)."""
    if not near(y[PHI + j] - y[PHI + i], sep):
        return 0.0, 0.0
    delta, rate, lever = pair_state(y, n, P, i, j)
    if delta <= 0.0:
        return 0.0, 0.0
    force, elastic = hertz_force(K, chi, delta, rate)
    Qc[j] += force * lever
    Qc[i] -= force * lever
    return 0.4 * elastic * delta, (elastic - force) * rate

@kernel
def hertz_force(K, chi, delta, rate):
    """(force, its elastic part) of the Hunt-Crossley law F = K delta^1.5 (1 + chi delta')
    >= 0 at an overlap delta > 0 (:func:`contact_forces`)."""
    elastic = K * delta * math.sqrt(delta)
    force = elastic * (1.0 + chi * rate)
    if force < 0.0:
        force = 0.0
    return force, elastic

@kernel
def contact_substeps(y, n, P, dt):
    """RK4 sub-steps per step of dt that keep omega_c h <= CONTACT_OMEGA_H (impacts) or
    CONTACT_OMEGA_H_REST (resting contacts) for every pair of balls that can touch within
    the step (issue 12). omega_c = sqrt(4 k_c / m_b) bounds a chain of balls, with k_c =
    1.5 K sqrt(delta_peak), delta_peak the Hertz peak overlap for the present overlap and
    approach speed; plus the contact damping rate."""
    return contact_regime(y, n, P, dt)[0]

@kernel
def contact_regime(y, n, P, dt):
    """(:func:`contact_substeps`, impact): impact is True when a pair that can touch within
    the step has more kinetic than static overlap (an impact, not a resting contact)."""
    return contact_regime_as(y, n, P, dt, False)

@kernel
def contact_regime_as(y, n, P, dt, every_impact):
    """:func:`contact_regime`, with every pair that can touch within the step resolved as an
    impact when ``every_impact`` (a step retaken after :func:`resting_misjudged`)."""
    k, impact, resting = contact_regimes(y, n, P, dt, every_impact)
    return k, impact

@kernel
def contact_regimes(y, n, P, dt, every_impact):
    """(:func:`contact_regime_as`, resting): resting is True when a pair was resolved as a
    resting contact (the step may have to be taken again, :func:`retake_substeps`)."""
    K, mb, sep = contact_scales(P)
    chi = P[I_CONTACT_DAMPING]
    N = PHI + n
    need = 0.0
    impact = False
    resting = False
    for i in range(n):
        for j in range(i + 1, n):
            reach = sep + 2.0 * abs(y[N + PHI + j] - y[N + PHI + i]) * dt
            if not near(y[PHI + j] - y[PHI + i], reach):
                continue
            delta, rate, lever = pair_state(y, n, P, i, j)
            if delta + 2.0 * max(rate, 0.0) * dt <= 0.0:
                continue
            static, kinetic = pair_energies(delta, rate, K, mb)
            peak = (static + kinetic) ** 0.4
            if peak <= 0.0:
                continue
            kc = 1.5 * K * math.sqrt(peak)
            w = math.sqrt(4.0 * kc / mb) + 2.0 * chi * K * peak * math.sqrt(peak) / mb
            if kinetic > static or every_impact:
                impact = True
                w /= CONTACT_OMEGA_H * impact_relaxation(static + kinetic, K, mb)
            else:
                resting = True
                w /= CONTACT_OMEGA_H_REST
            if w > need:
                need = w
    k = int(math.ceil(need * dt))
    if k < 1:
        k = 1
    if k > MAX_SUBSTEPS:
        k = MAX_SUBSTEPS
    return k, impact, resting

@kernel
def contact_scales(P):
    """(K of :func:`contact_stiffness`, a ball's mass m_b (7/5 m for rolling balls), the
    angle 2 asin(r / R) at which two balls touch) of :func:`contact_regime_as`."""
    mb = P[6] * (1.0 + SPIN_INERTIA * P[I_BALL_ROTATION])
    return contact_stiffness(P), mb, 2.0 * math.asin(P[I_R_BALL] / P[3])

@kernel
def pair_energies(delta, rate, K, mb):
    """(static, kinetic) overlap 'energies' of a pair at overlap delta and its rate, in
    delta^2.5: the present overlap's, max(delta, 0)^2.5, and the Hertz peak overlap's of the
    rate, 5/8 m_b rate^2 / K (:func:`contact_regime_as`). More kinetic than static: an impact,
    else a resting contact."""
    d0 = max(delta, 0.0)
    return d0 * d0 * math.sqrt(d0), 0.625 * mb * rate * rate / K

@kernel
def resting_misjudged(y0, y1, n, P, dt):
    """True when a pair of balls that :func:`contact_regime` took for a resting contact at
    y0 (touching, its overlap's energy at least its rate's) did not rest over the step of dt
    to y1: its overlap there is under half or over twice that at y0, its rate's energy
    exceeds its overlap's, or its force was not carried: its rate changed by more than
    CONTACT_REST_IMBALANCE of 2 K delta^1.5 dt / m_b, what the contact force at y0 alone
    would change it by. From the state alone an impact caught near its peak looks like a
    resting contact; resolved as one (CONTACT_OMEGA_H_REST), its rebound would be wrong by
    up to a few % of the impact's speed (the step across the peak changes neither the
    overlap nor the energies much, but it turns the rate round)."""
    K, mb, sep = contact_scales(P)
    for i in range(n):
        for j in range(i + 1, n):
            if not near(y0[PHI + j] - y0[PHI + i], sep):
                continue
            delta, rate, lever = pair_state(y0, n, P, i, j)
            static, kinetic = pair_energies(delta, rate, K, mb)
            if delta <= 0.0 or kinetic > static:
                continue                        # apart, or an impact (resolved as one)
            d1, r1, lever = pair_state(y1, n, P, i, j)
            if d1 < 0.5 * delta or d1 > 2.0 * delta:
                return True
            if abs(r1 - rate) * mb > CONTACT_REST_IMBALANCE * 2.0 * K * static / delta * dt:
                return True                     # (K delta^1.5 = K static / delta)
            static, kinetic = pair_energies(d1, r1, K, mb)
            if kinetic > static:
                return True
    return False

@kernel
def retake_substeps(start, y, n, P, dt, impact, used, refine):
    """Sub-steps to take the step of dt from ``start`` (which gave y in ``used`` sub-steps)
    again with every contact resolved as an impact (:func:`contact_regime_as`, times
    ``refine``), or 0: only a step resolved as resting (not ``impact``) whose resting contact
    did not rest (:func:`resting_misjudged`) and when an impact needs more sub-steps than
    ``used`` (a step that an impact would take whole is not taken again)."""
    if impact or not resting_misjudged(start, y, n, P, dt):
        return 0
    forced = contact_regime_as(start, n, P, dt, True)[0]
    return int(math.ceil(forced * refine)) if forced > used else 0

@kernel
def contact_step(t, dt, y, start, n, P, S, sub, impact, trace, qdd, A, W, f, B, fb, u):
    """The multirate step of dt from (t, y), y in place (``start``: a copy of y, kept), with
    the fast sub-steps of :func:`contact_regime`'s (``sub``, ``impact``)
    (:func:`mis_substeps`), taken again from ``start`` when :func:`retake_substeps` says so.
    Returns the fast sub-steps (``trace``'s rows, of the step kept), as
    :func:`mis_contact_step`."""
    fast = int(math.ceil(sub * MIS_IMPACT_REFINE)) if impact else sub
    rows = mis_contact_step(t, dt, y, n, P, S, fast, trace, qdd, A, W, f, B, fb, u)
    forced = retake_substeps(start, y, n, P, dt, impact, fast, MIS_IMPACT_REFINE)
    if forced > 0:
        y[:] = start
        rows = mis_contact_step(t, dt, y, n, P, S, forced, trace, qdd, A, W, f, B, fb, u)
    return rows

@kernel
def impact_relaxation(energy, K, mb):
    """How many times longer than CONTACT_OMEGA_H / omega_c the sub-steps of an impact may be
    (>= 1): the impact's speed v (from its peak overlap's ``energy`` = delta_peak^2.5, as in
    :func:`contact_regime`) below CONTACT_IMPACT_SPEED keeps the rebound speed's error
    (relative error x v) at what the impact at that speed has, (CONTACT_IMPACT_SPEED / v) ^
    (1 / CONTACT_ERROR_ORDER), at most CONTACT_RELAX_MAX."""
    v = math.sqrt(energy * K / (0.625 * mb))
    if v * CONTACT_RELAX_MAX ** CONTACT_ERROR_ORDER <= CONTACT_IMPACT_SPEED:
        return CONTACT_RELAX_MAX
    if v >= CONTACT_IMPACT_SPEED:
        return 1.0
    return (CONTACT_IMPACT_SPEED / v) ** (1.0 / CONTACT_ERROR_ORDER)

@kernel
def mis_substeps(y, n, P, dt):
    """Fast RK4 sub-steps of :func:`mis_contact_step` for the step of dt from y:
    :func:`contact_substeps`, times MIS_IMPACT_REFINE in an impact (:func:`contact_regime`)."""
    sub, impact = contact_regime(y, n, P, dt)
    return int(math.ceil(sub * MIS_IMPACT_REFINE)) if impact else sub

@kernel
def neighbour_pairs(y, n):
    """The pairs of balls next to each other on the race, (n, 2) (one pair for n = 2): the
    balls sorted by angle, each with the next (cyclically). Balls in contact cannot pass each
    other, so only these pairs can touch within a step."""
    angle = np.empty(n)
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        a = y[PHI + i] - 2.0 * math.pi * math.floor(y[PHI + i] / (2.0 * math.pi))
        k = i
        while k > 0 and angle[k - 1] > a:       # insertion sort
            angle[k] = angle[k - 1]
            order[k] = order[k - 1]
            k -= 1
        angle[k] = a
        order[k] = i
    npairs = 1 if n == 2 else n
    pairs = np.empty((npairs, 2), dtype=np.int64)
    for k in range(npairs):
        pairs[k, 0] = order[k]
        pairs[k, 1] = order[(k + 1) % n]
    return pairs

@kernel
def neighbour_reference(y, n, pairs, ref):
    """ref[k] = [its wrap 2 pi w, half-angle h0, sin h0, cos h0] of neighbour pair k at y
    (half = (phi_j - phi_i - 2 pi w) / 2 as in :func:`pair_state`), the reference of
    :func:`mis_fast_solve` within the step."""
    for k in range(pairs.shape[0]):
        d = y[PHI + pairs[k, 1]] - y[PHI + pairs[k, 0]]
        w = 2.0 * math.pi * math.floor(d / (2.0 * math.pi) + 0.5)
        half = 0.5 * (d - w)
        ref[k, 0] = w
        ref[k, 1] = half
        ref[k, 2] = math.sin(half)
        ref[k, 3] = math.cos(half)

@kernel
def sincos_near(h0, s0, c0, e):
    """(sin, cos) of h0 + e from s0 = sin h0 and c0 = cos h0: the addition theorem with
    the Taylor series of sin e and cos e (round-off for |e| < 0.1), else math.sin, cos."""
    if abs(e) >= 0.1:
        return math.sin(h0 + e), math.cos(h0 + e)
    e2 = e * e
    sin_e = e * (1.0 - e2 * (1.0 / 6.0) * (1.0 - e2 * (1.0 / 20.0) * (
        1.0 - e2 * (1.0 / 42.0) * (1.0 - e2 * (1.0 / 72.0)))))
    cos_e = 1.0 - e2 * 0.5 * (1.0 - e2 * (1.0 / 12.0) * (1.0 - e2 * (1.0 / 30.0) * (
        1.0 - e2 * (1.0 / 56.0) * (1.0 - e2 * (1.0 / 90.0)))))
    return s0 * cos_e + c0 * sin_e, c0 * cos_e - s0 * sin_e

@kernel
def velocity_coupling(y, n, P, inv, Ainv, W, B, Jv):
    """Jv[:, b] = d q'' / d phi_b' at y (N x n), of the terms of :func:`assemble` and
    :func:`add_ball_rotation` in the balls' rates psi_b' = theta' + phi_b' (Eqs. 18-22:
    Coriolis and centrifugal; the ball's drag D), through the coupled system: Ainv the
    inverse of the eliminated deck rows, W and B as :func:`accel` leaves them, inv =
    1 / m R^2."""
    N = PHI + n
    R, m, D = P[3], P[6], P[15]
    mr = m * R
    mr2 = mr * R
    JbRr = SPIN_INERTIA * m * R * P[I_R_BALL] if P[I_BALL_ROTATION] != 0.0 else 0.0
    al, be, ga = y[DECK + 3], y[DECK + 4], y[DECK + 5]
    ald, bed, gad = y[N + DECK + 3], y[N + DECK + 4], y[N + DECK + 5]
    df = np.empty(6)
    du = np.empty(6)
    for b in range(n):
        psi = y[THETA] + y[PHI + b]
        psid = y[N + THETA] + y[N + PHI + b]
        s = math.sin(psi)
        co = math.cos(psi)
        df[0] = mr * (-2.0 * psid * ga * s + 2.0 * (gad + psid) * co)
        df[1] = mr * (2.0 * psid * ga * co + 2.0 * (gad + psid) * s)
        df[2] = -2.0 * mr * ((ald + psid * be) * co + (bed - psid * al) * s)
        df[3] = -2.0 * mr2 * s * (co * ald + s * bed) + JbRr * bed
        df[4] = 2.0 * mr2 * co * (s * bed + co * ald) - JbRr * ald
        df[5] = 0.0
        for row in range(6):
            df[row] += W[row, b] * D * inv        # the ball row's -D, eliminated
        for row in range(6):
            du[row] = 0.0
            for col in range(6):
                du[row] += Ainv[row, col] * df[col]
        Jv[THETA, b] = 0.0
        for row in range(6):
            Jv[DECK + row, b] = du[row]
        for c in range(n):
            Jv[PHI + c, b] = -inv * (B[c, 0] * du[0] + B[c, 1] * du[1] + B[c, 5] * du[5])
        Jv[PHI + b, b] -= inv * D

@kernel
def mis_fast_solve(t0, m, h, y, n, P, reach, inv, pairs, ref, Ainv, psi, Jv, Bs, v0, g, Qc, sc,
                   k, yt, trace, rows):
    """m RK4 sub-steps of h from (t0, y), y in place, of the fast part of
    :func:`mis_contact_step`: q' = q-dot, q-dot' = g + C0 Qc + Jv (phi' - v0); while no pair
    of balls touches or can touch soon, several of them as one (:func:`apart_substeps`: the
    fast part is then free of contact forces). Rows of ``trace`` from ``rows`` on, one per
    (merged) sub-step; returns the next row. (One function with its right-hand side
    inline: a sub-step is a few hundred flops, a kernel call per stage would cost as much.)

    Qc: the contact forces of the neighbour pairs (:func:`pair_state`, :func:`hertz_force`;
    reach = asin(r / R), the half-angle of contact; the half-angles' sines from the step's
    reference ``ref`` by :func:`sincos_near`). C0 Qc: the accelerations they cause through the
    coupled system, ``inv`` = 1 / m R^2 (ball elimination), Ainv the inverse of the eliminated
    deck rows at the step's start: deck u = Ainv (-inv W Qc), ball b (Qc_b - B_b u) inv, with
    W and B at the present angles psi_b = theta + phi_b (``psi``: rows [phi_b, sin psi_b,
    cos psi_b] of the step's start and [theta]; the rotor's turn by :func:`sincos_near`, the
    ball's own, at most ~1e-2 within a step, to third order; R, r, inv include the rolling
    balls' spin). Jv (phi' - v0): the change of the balls' Coriolis, centrifugal and drag terms
    with their rates since the step's start (:func:`velocity_coupling`), applied in its
    factored form: the deck rows of Jv, then the ball rows as -inv (B s) through ``Bs``
    (n, 3; columns 0, 1, 5 of the step's start's B) plus the balls' own drag. k (4, 2N), yt
    (2N): stage buffers; Qc (n), sc (2, n: the balls' sin, cos psi_b at a stage) scratch."""
    N = PHI + n
    n2 = 2 * N
    R, r = P[3], P[I_R_BALL]
    K = contact_stiffness(P)
    chi = P[I_CONTACT_DAMPING]
    mr = P[6] * R
    mr2 = mr * R - (SPIN_INERTIA * P[6] * R * r if P[I_BALL_ROTATION] != 0.0 else 0.0)
    inv_d = inv * P[15]
    s = 0
    while s < m:
        merged = apart_substeps(y, n, reach, pairs, ref, h, m - s)
        hs = merged * h
        for stage in range(4):
            a = 0.0 if stage == 0 else (hs if stage == 3 else 0.5 * hs)
            for i in range(n2):
                yt[i] = y[i] + a * k[stage - 1, i] if stage > 0 else y[i]
            dy = k[stage]
            for i in range(n):
                Qc[i] = 0.0
            touching = False
            for p in range(pairs.shape[0]):
                i = pairs[p, 0]
                j = pairs[p, 1]
                half = 0.5 * (yt[PHI + j] - yt[PHI + i] - ref[p, 0])
                if abs(half) >= reach:
                    continue                    # apart
                sh, ch = sincos_near(ref[p, 1], ref[p, 2], ref[p, 3], half - ref[p, 1])
                lever = R * ch if half >= 0.0 else -R * ch
                delta = 2.0 * r - 2.0 * R * abs(sh)
                if delta <= 0.0:
                    continue
                force, _ = hertz_force(K, chi, delta,
                                       -lever * (yt[N + PHI + j] - yt[N + PHI + i]))
                Qc[j] += force * lever
                Qc[i] -= force * lever
                touching = True
            for i in range(N):
                dy[i] = yt[N + i]
                dy[N + i] = g[i]
            # Jv (phi' - v0), Jv of rank 3 in the ball rows (velocity_coupling): the deck's
            # part s, the balls' -inv (B s) and their own drag -inv D (phi' - v0)
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            s3 = 0.0
            s4 = 0.0
            s5 = 0.0
            for b in range(n):
                dv = yt[N + PHI + b] - v0[b]
                s0 += Jv[DECK, b] * dv
                s1 += Jv[DECK + 1, b] * dv
                s2 += Jv[DECK + 2, b] * dv
                s3 += Jv[DECK + 3, b] * dv
                s4 += Jv[DECK + 4, b] * dv
                s5 += Jv[DECK + 5, b] * dv
                dy[N + PHI + b] -= inv_d * dv
            dy[N + DECK] += s0
            dy[N + DECK + 1] += s1
            dy[N + DECK + 2] += s2
            dy[N + DECK + 3] += s3
            dy[N + DECK + 4] += s4
            dy[N + DECK + 5] += s5
            for c in range(n):
                dy[N + PHI + c] -= inv * (Bs[c, 0] * s0 + Bs[c, 1] * s1 + Bs[c, 2] * s5)
            if not touching:
                continue
            al, be, ga = yt[DECK + 3], yt[DECK + 4], yt[DECK + 5]
            st, ct = sincos_near(0.0, 0.0, 1.0, yt[THETA] - psi[n, 0])     # the rotor's turn
            w0 = 0.0
            w1 = 0.0
            w2 = 0.0
            w5 = 0.0
            for b in range(n):
                sb, cb = ball_sincos(psi, st, ct, b, yt[PHI + b])
                sc[0, b] = sb
                sc[1, b] = cb
                q = -inv * Qc[b]
                if q != 0.0:                    # -inv W Qc (W of assemble at yt)
                    w0 -= mr * (sb + ga * cb) * q
                    w1 += mr * (cb - ga * sb) * q
                    w2 += mr * (al * cb + be * sb) * q
                    w5 += mr2 * q
            w3 = be * w5
            u0 = 0.0
            u1 = 0.0
            u5 = 0.0
            for row in range(6):
                ur = (Ainv[row, 0] * w0 + Ainv[row, 1] * w1 + Ainv[row, 2] * w2
                      + Ainv[row, 3] * w3 + Ainv[row, 5] * w5)
                dy[N + DECK + row] += ur
                if row == 0:
                    u0 = ur
                elif row == 1:
                    u1 = ur
                elif row == 5:
                    u5 = ur
            for b in range(n):                  # inv (Qc - B u) (B of assemble at yt)
                dy[N + PHI + b] += inv * (Qc[b] + mr * sc[0, b] * u0 - mr * sc[1, b] * u1
                                          - mr2 * u5)
        for i in range(n2):
            y[i] = y[i] + hs / 6.0 * (k[0, i] + 2.0 * (k[1, i] + k[2, i]) + k[3, i])
        if rows < trace.shape[0]:
            trace[rows, 0] = t0 + s * h
            trace[rows, 1] = hs
            for i in range(n2):
                trace[rows, 2 + i] = y[i]
        rows += 1
        s += merged
    return rows

@kernel
def apart_substeps(y, n, reach, pairs, ref, h, left):
    """How many of the ``left`` fast sub-steps of h from y :func:`mis_fast_solve` may take
    as one RK4 step: 1 while a neighbour pair touches, else as many as keep every pair apart
    by MIS_APART_MARGIN times its closing at its present rate (no contact force can act
    within them; the fast part is then as smooth as the slow one)."""
    N = PHI + n
    soonest = left * h * MIS_APART_MARGIN
    for p in range(pairs.shape[0]):
        i = pairs[p, 0]
        j = pairs[p, 1]
        half = 0.5 * (y[PHI + j] - y[PHI + i] - ref[p, 0])
        ah = abs(half)
        if ah < reach:
            return 1                            # touching (the reach of the Hertz law)
        # the half-angle closes at |d half/dt| towards reach; contact when it gets there
        closing = -0.5 * (y[N + PHI + j] - y[N + PHI + i]) * (1.0 if half >= 0.0 else -1.0)
        if closing > 0.0:
            time = (ah - reach) / closing
            if time < soonest:
                soonest = time
    merged = int(soonest / (h * MIS_APART_MARGIN))
    if merged < 1:
        return 1
    return merged if merged < left else left

@kernel
def ball_sincos(psi, st, ct, b, phi):
    """(sin, cos) of ball b's psi_b = theta + phi: its step-start values ``psi[b]`` turned by
    the rotor's (st, ct) and by its own phi - phi_b0 to third order (:func:`mis_fast_solve`)."""
    sr = psi[b, 1] * ct + psi[b, 2] * st
    cr = psi[b, 2] * ct - psi[b, 1] * st
    d = phi - psi[b, 0]
    d2 = 1.0 - 0.5 * d * d
    return sr * d2 + cr * d, cr * d2 - sr * d

@kernel
def mis_contact_step(t, dt, y, n, P, S, sub, trace, qdd, A, W, f, B, fb, u):
    """One step of dt from (t, y) while balls touch (issue 12), y in place: multirate
    infinitesimal step (MIS: Wensch, Knoth, Galant 2009) on Knoth & Wolke's three-stage RK
    (third order, :data:`MIS_A`, :data:`MIS_C`).

    The right-hand side is split into a fast part, the positions' rates, the accelerations
    C0 Qc that the contact forces of the neighbour pairs cause through the coupled system
    and the linear change of the rate-dependent terms with the balls' rates since the step's
    start (an impact changes them within a step; :func:`mis_fast_solve`), and a slow part,
    the accelerations without contact (:func:`accel`) minus that linear change (so that no
    contact spike is sampled at a stage). The slow part is evaluated at the three stages
    only; from stage to stage the fast part is integrated by RK4 sub-steps of at most
    dt / sub with the slow part's stage combination as a constant forcing: a sub-step costs
    O(n), not a coupled solve. Row r of ``trace`` (when it has rows) receives sub-step r:
    [its start time, its length, the state after it]; qdd and the rest: the scratch of
    :func:`accel`. Returns the number of sub-steps. Speed-driven spindle, no rolling resistance
    (:func:`rk4_step_located`)."""
    N = PHI + n
    inv = 1.0 / ball_inertia(P)
    reach = math.asin(P[I_R_BALL] / P[3])
    pairs = neighbour_pairs(y, n)
    ref = np.empty((pairs.shape[0], 4))
    neighbour_reference(y, n, pairs, ref)
    Ainv = np.empty((6, 6))
    psi = np.empty((n + 1, 3))
    for b in range(n):
        psi[b, 0] = y[PHI + b]
        psi[b, 1] = math.sin(y[THETA] + y[PHI + b])
        psi[b, 2] = math.cos(y[THETA] + y[PHI + b])
    psi[n, 0] = y[THETA]
    Jv = np.empty((N, n))
    Bs = np.empty((n, 3))
    v0 = y[N + PHI:].copy()
    k = np.empty((4, 2 * N))
    yt = np.empty(2 * N)
    F = np.empty((3, N))
    g = np.zeros(N)
    Qc = np.empty(n)
    sc = np.empty((2, n))
    rows = 0
    P_slow = P.copy()
    P_slow[I_CONTACT_E] = 0.0
    for i in range(3):
        t_i = t + MIS_C[i] * dt
        accel(t_i, y, n, P_slow, S, qdd, A, W, f, B, fb, u)
        if i == 0:
            # A is now the eliminated deck matrix: its inverse, column by column
            for col in range(6):
                for row in range(6):
                    f[row] = 1.0 if row == col else 0.0
                solve_deck(A, f, u)
                for row in range(6):
                    Ainv[row, col] = u[row]
            velocity_coupling(y, n, P, inv, Ainv, W, B, Jv)
            for b in range(n):      # B's columns of Jv's ball rows, at the step's start
                Bs[b, 0] = B[b, 0]
                Bs[b, 1] = B[b, 1]
                Bs[b, 2] = B[b, 5]
        # the slow part at stage i: accel without contact minus Jv (phi' - v0)
        for c in range(N):
            F[i, c] = qdd[c]
        for b in range(n):
            dv = y[N + PHI + b] - v0[b]
            for c in range(N):
                F[i, c] -= Jv[c, b] * dv
        span = MIS_C[i + 1] - MIS_C[i]
        for c in range(N):
            s = 0.0
            for j in range(i + 1):
                s += (MIS_A[i + 1, j] - MIS_A[i, j]) * F[j, c]
            g[c] = s / span
        m = max(1, int(math.ceil(sub * span - 1e-9)))
        rows = mis_fast_solve(t_i, m, span * dt / m, y, n, P, reach, inv, pairs, ref, Ainv, psi,
                              Jv, Bs, v0, g, Qc, sc, k, yt, trace, rows)
    return rows

@kernel
def solve3(A, f, i0, i1, i2, u):
    """u[i] for i in (i0, i1, i2) from rows and columns (i0, i1, i2) of A u = f: Gaussian
    elimination with partial pivoting on the 3 x 3 block (A and f are not modified)."""
    a00, a01, a02 = A[i0, i0], A[i0, i1], A[i0, i2]
    a10, a11, a12 = A[i1, i0], A[i1, i1], A[i1, i2]
    a20, a21, a22 = A[i2, i0], A[i2, i1], A[i2, i2]
    b0, b1, b2 = f[i0], f[i1], f[i2]
    # pivot column 0
    if abs(a10) > abs(a00) and abs(a10) >= abs(a20):
        a00, a01, a02, b0, a10, a11, a12, b1 = a10, a11, a12, b1, a00, a01, a02, b0
    elif abs(a20) > abs(a00):
        a00, a01, a02, b0, a20, a21, a22, b2 = a20, a21, a22, b2, a00, a01, a02, b0
    l1 = a10 / a00
    l2 = a20 / a00
    a11 -= l1 * a01
    a12 -= l1 * a02
    b1 -= l1 * b0
    a21 -= l2 * a01
    a22 -= l2 * a02
    b2 -= l2 * b0
    # pivot column 1
    if abs(a21) > abs(a11):
        a11, a12, b1, a21, a22, b2 = a21, a22, b2, a11, a12, b1
    l2 = a21 / a11
    a22 -= l2 * a12
    b2 -= l2 * b1
    x2 = b2 / a22
    x1 = (b1 - a12 * x2) / a11
    x0 = (b0 - a01 * x1 - a02 * x2) / a00
    u[i0] = x0
    u[i1] = x1
    u[i2] = x2

@kernel
def solve_deck(A, f, u):
    """Deck accelerations u from A u = f. To the paper's order the in-plane rows (X, Y,
    gamma: Eqs. 18, 19, 23 with the balls eliminated) hold no out-of-plane acceleration,
    so the system is block triangular: a 3 x 3 in-plane solve, then a 3 x 3 out-of-plane
    solve (Z, alpha, beta) with the in-plane accelerations moved to the right."""
    solve3(A, f, 0, 1, 5, u)
    for r in range(2, 5):
        f[r] -= A[r, 0] * u[0] + A[r, 1] * u[1] + A[r, 5] * u[5]
    solve3(A, f, 2, 3, 4, u)

@kernel
def motor_current(omega, S):
    """Winding current [A] of the current-commanded DC/BLDC drive (S of mode 3): the
    command, limited by the supply voltage (R_w i + K_t omega within +-V_s, back-EMF
    constant K_e = K_t in SI), then clipped to +-I_max (inductance neglected: the current
    loop is much faster than the mechanics)."""
    i = S[1]
    K_t, R_w, i_max, V_s = S[2], S[3], S[4], S[8]
    hi = (V_s - K_t * omega) / R_w
    lo = (-V_s - K_t * omega) / R_w
    if i > hi:
        i = hi
    elif i < lo:
        i = lo
    if i > i_max:
        i = i_max
    elif i < -i_max:
        i = -i_max
    return i


@kernel
def spindle_torque(omega, S):
    """Q_theta [N m]: motor torque K_t i minus bearing friction b_v omega + T_c
    tanh(omega / omega_c) (Coulomb friction smoothed over omega_c)."""
    return S[2] * motor_current(omega, S) - S[5] * omega - S[6] * math.tanh(omega / S[7])


@kernel
def theta_row(y, n, P, a, col):
    """The free-theta equation to first order in the deck coordinates (docs/torque_mode.md):

        (J_z + I_r)(theta'' + gamma'') - S1 X'' + C1 Y'' + m R^2 sum phi_i'' = Q_theta,

    I_r = M eps^2 + n m R^2, S1, C1 = sum mu r (sin, cos) psi over G and the balls. Fills
    ``a`` (6) with its deck coefficients and ``col`` (6) with the coefficients of theta'' in
    the deck rows of :func:`assemble` (the terms it moves to the right when theta'' is
    known); returns J_z + I_r, the coefficient of theta'' (the balls' column is m R^2)."""
    R, M, m, J_z, eps = P[3], P[5], P[6], P[12], P[16]
    al, be, ga = y[DECK + 3], y[DECK + 4], y[DECK + 5]
    S1 = 0.0
    C1 = 0.0
    for j in range(n + 1):
        if j == 0:
            mr = M * eps
            psi = y[THETA]
        else:
            mr = m * R
            psi = y[THETA] + y[PHI - 1 + j]
        S1 += mr * math.sin(psi)
        C1 += mr * math.cos(psi)
    I_th = J_z + M * eps * eps + n * m * R * R
    a[0] = -S1
    a[1] = C1
    a[2] = 0.0
    a[3] = 0.0
    a[4] = 0.0
    a[5] = I_th
    col[0] = -S1 - ga * C1
    col[1] = C1 - ga * S1
    col[2] = al * C1 + be * S1
    col[3] = be * I_th
    col[4] = 0.0
    col[5] = I_th
    return I_th


@kernel
def eliminate_balls(n, inv, A, W, f, B, fb):
    """Schur complement of the ball rows in the deck rows (the balls' block is m R^2 I,
    ``inv`` its inverse): A -= W B / m R^2, f -= W fb / m R^2, in place."""
    for i in range(6):
        for b in range(n):
            w = W[i, b] * inv
            if w != 0.0:
                # Eq. (24) involves X'', Y'' and gamma'' only (B[:, 2:5] = 0)
                A[i, 0] -= w * B[b, 0]
                A[i, 1] -= w * B[b, 1]
                A[i, 5] -= w * B[b, 5]
                f[i] -= w * fb[b]


@kernel
def solver_scratch(n):
    """Scratch arrays (A, W, f, B, fb, u) of :func:`accel` for n balls."""
    nb = max(n, 1)
    return (np.empty((6, 6)), np.empty((6, nb)), np.empty(6), np.empty((nb, 6)),
            np.empty(nb), np.empty(6))


@kernel
def accel_free_theta(t, y, n, P, S, qdd, A, W, f, B, fb, u):
    """q'' with theta a degree of freedom driven by Q_theta = :func:`spindle_torque`.

    The deck and ball rows of :func:`assemble` (assembled with theta'' = 0, the column of
    theta'' from :func:`theta_row`) and the theta row: the balls are eliminated from both
    (block m R^2 I), the deck solved for the right-hand side and for theta'''s column
    (:func:`solve_deck`), theta'' from the theta row (a scalar Schur complement, the
    rotor inertia the motor sees), then back-substitution."""
    N = PHI + n
    assemble(y, n, P, 0.0, A, W, f, B, fb)
    a = np.empty(6)
    col = np.empty(6)
    uc = np.empty(6)
    I_th = theta_row(y, n, P, a, col)
    Q = spindle_torque(y[N + THETA], S)
    mR2 = P[6] * P[3] * P[3]
    inv = 1.0 / mR2
    eliminate_balls(n, inv, A, W, f, B, fb)
    for i in range(6):
        for b in range(n):
            w = W[i, b] * inv
            if w != 0.0:
                col[i] -= w * mR2
    for b in range(n):
        # in the theta row, m R^2 phi_b'' = fb_b - B_b u - m R^2 theta''
        a[0] -= B[b, 0]
        a[1] -= B[b, 1]
        a[5] -= B[b, 5]
        Q -= fb[b]
        I_th -= mR2
    solve_deck(A, f, u)
    solve_deck(A, col, uc)
    num = Q
    den = I_th
    for i in range(6):
        num -= a[i] * u[i]
        den -= a[i] * uc[i]
    thdd = num / den
    qdd[THETA] = thdd
    for i in range(6):
        u[i] -= uc[i] * thdd
        qdd[DECK + i] = u[i]
    for b in range(n):
        acc = fb[b] - mR2 * thdd
        for j in range(6):
            acc -= B[b, j] * u[j]
        qdd[PHI + b] = acc * inv

@kernel
def accel(t, y, n, P, S, qdd, A, W, f, B, fb, u):
    """q'' at (t, y): eliminate the ball accelerations (their block is m R^2 I: Schur
    complement), solve the deck (:func:`solve_deck`), then back-substitute the balls."""
    if S[0] == SPINDLE_TORQUE:
        accel_free_theta(t, y, n, P, S, qdd, A, W, f, B, fb, u)
        return
    N = PHI + n
    thdd = spindle_accel(t, y[N + THETA], S)
    assemble(y, n, P, thdd, A, W, f, B, fb)
    mR2 = ball_inertia(P)
    if P[I_ROLLING_MU] > 0.0 and n > 0:
        Qf = np.empty(n)
        mode = np.empty(n)
        accel_rolling(y, n, P, mR2, qdd, A, W, f, B, fb, u, Qf, mode, False)
        qdd[0] = thdd
        return
    inv = 1.0 / mR2
    eliminate_balls(n, inv, A, W, f, B, fb)
    solve_deck(A, f, u)
    qdd[THETA] = thdd
    for i in range(6):
        qdd[DECK + i] = u[i]
    for b in range(n):
        acc = fb[b]
        for j in range(6):
            acc -= B[b, j] * u[j]
        qdd[PHI + b] = acc * inv

@kernel
def ball_inertia(P):
    """m R^2 of a ball's row, times 7/5 for rolling balls (J_b (R/r)^2 = 2/5 m R^2)."""
    mR2 = P[6] * P[3] * P[3]
    if P[I_BALL_ROTATION] != 0.0:
        mR2 += SPIN_INERTIA * mR2
    return mR2

@kernel
def rolling_threshold(y, n, P, b):
    """Largest rolling-resistance generalized force on ball b [N m]: torque mu N about the
    contact, N = m R psi_b'^2 the centrifugal load on the race (first order), as a force
    mu N / r at the centre, times R (issue 12)."""
    N = PHI + n
    psid = y[N] + y[N + PHI + b]
    R = P[3]
    return P[I_ROLLING_MU] * P[6] * R * psid * psid / P[I_R_BALL] * R

@kernel
def accel_rolling(y, n, P, mR2, qdd, A, W, f, B, fb, u, Qf, mode, frozen):
    """q'' (deck and balls) with rolling resistance: Coulomb with a Karnopp stick band.

    Band: |phi_b'| < max(rolling_stick_rate, Qmax_b / (m_eff R^2) STICK_TIME), i.e. speeds
    the rolling resistance alone would take away within STICK_TIME count as rest (a slipping
    ball cannot jump across the band in one step of dt <= STICK_TIME; a narrower band makes
    it chatter around zero speed). Outside the band the ball slips: Qf_b = -Qmax_b
    sign(phi_b'). Inside it the ball sticks: phi_b'' = -phi_b' / STICK_TIME, and Qf_b is
    whatever force that takes (solved with the deck, all balls coupled) while |Qf_b| <= Qmax_b;
    where it would exceed Qmax_b the ball breaks free with Qf_b = Qmax_b sign(Qf_b), and the
    rest are solved again (at most n + 1 solves). Qf receives the forces.

    Regimes, one per ball in ``mode``: 0 stuck, +-1 slipping outside the band, +-2 broken
    free inside it (Qf_b = sign(mode_b) Qmax_b). ``frozen`` False: the regimes of the state,
    written to ``mode``; True: ``mode`` is kept, each regime's law continued smoothly past its
    boundary (event-located switching, :func:`rk4_rolling_substep`). Returns the switching
    function :func:`rolling_margin` of the regimes.
    """
    N = PHI + n
    A0 = A.copy()
    f0 = f.copy()
    inv = 1.0 / mR2
    Qmax = np.empty(n)
    band = np.empty(n)
    target = np.empty(n)
    for b in range(n):
        rate = y[N + PHI + b]
        Qmax[b] = rolling_threshold(y, n, P, b)
        # the band: rolling_stick_rate, or the speed the rolling resistance alone takes away
        # in STICK_TIME if larger (so that a step of dt <= STICK_TIME cannot jump across it)
        band[b] = max(P[I_STICK_RATE], Qmax[b] * inv * STICK_TIME)
        target[b] = -rate / STICK_TIME
        if not frozen:
            if abs(rate) < band[b]:
                mode[b] = 0.0
            else:
                mode[b] = -1.0 if rate > 0.0 else 1.0
        Qf[b] = 0.0 if mode[b] == 0.0 else math.copysign(Qmax[b], mode[b])
    for _ in range(n + 1):
        for i in range(6):
            f[i] = f0[i]
            for j in range(6):
                A[i, j] = A0[i, j]
        for i in range(6):
            for b in range(n):
                if mode[b] == 0.0:
                    f[i] -= W[i, b] * target[b]
                else:
                    w = W[i, b] * inv
                    A[i, 0] -= w * B[b, 0]
                    A[i, 1] -= w * B[b, 1]
                    A[i, 5] -= w * B[b, 5]
                    f[i] -= w * (fb[b] + Qf[b])
        solve_deck(A, f, u)
        released = False
        for b in range(n):
            if mode[b] == 0.0:
                need = mR2 * target[b] - fb[b]
                for j in range(6):
                    need += B[b, j] * u[j]
                if not frozen and abs(need) > Qmax[b]:
                    mode[b] = 2.0 if need > 0.0 else -2.0
                    Qf[b] = math.copysign(Qmax[b], need)
                    released = True
                else:
                    Qf[b] = need
        if not released:
            break
    for i in range(6):
        qdd[1 + i] = u[i]
    for b in range(n):
        if mode[b] == 0.0:
            qdd[PHI + b] = target[b]
        else:
            acc = fb[b] + Qf[b]
            for j in range(6):
                acc -= B[b, j] * u[j]
            qdd[PHI + b] = acc * inv
    return rolling_margin(y, n, mode, Qmax, band, Qf, qdd, mR2)

@kernel
def rolling_margin(y, n, mode, Qmax, band, Qf, qdd, mR2):
    """Switching function of the rolling regimes ``mode`` at y (forces Qf, accelerations qdd):
    the least over the balls of a dimensionless margin, >= 0 while each stays in its regime.
    Stuck: inside the band (1 - |phi'| / band) and holding (1 - |Qf| / Qmax); slipping: outside
    the band on its side (-sign(mode) phi' / band - 1); broken free: still short of the stuck
    acceleration -phi' / STICK_TIME in the direction of its force (sign(mode) (-phi' /
    STICK_TIME - phi'') m R^2 / Qmax)."""
    N = PHI + n
    margin = math.inf
    for b in range(n):
        rate = y[N + PHI + b]
        scale = Qmax[b] if Qmax[b] > 0.0 else 1.0
        if mode[b] == 0.0:
            g = min(1.0 - abs(rate) / band[b], 1.0 - abs(Qf[b]) / scale)
        elif abs(mode[b]) == 1.0:
            g = -mode[b] * rate / band[b] - 1.0
        else:
            g = math.copysign(mR2 / scale, mode[b]) * (-rate / STICK_TIME - qdd[PHI + b])
        if g < margin:
            margin = g
    return margin

@kernel
def rolling_deriv(t, y, n, P, S, mode, frozen, dy, qdd, Qf, A, W, f, B, fb, u):
    """y' at (t, y) with rolling resistance and a speed-driven spindle, the regimes ``mode``
    determined (``frozen`` False) or kept (True), forces into Qf (:func:`accel_rolling`);
    returns the switching function."""
    N = PHI + n
    thdd = spindle_accel(t, y[N + THETA], S)
    assemble(y, n, P, thdd, A, W, f, B, fb)
    margin = accel_rolling(y, n, P, ball_inertia(P), qdd, A, W, f, B, fb, u, Qf, mode, frozen)
    qdd[THETA] = thdd
    for i in range(N):
        dy[i] = y[N + i]
        dy[N + i] = qdd[i]
    return margin

@kernel
def ball_forces(t, y, n, P, S, Qc, Qf):
    """Diagnostics (issue 12): contact forces Qc and rolling-resistance forces Qf on the ball
    rows at (t, y); returns (contact energy [J], contact damping power [W])."""
    N = PHI + n
    A, W, f, B, fb, u = solver_scratch(n)
    qdd = np.empty(N)
    energy = 0.0
    power = 0.0
    for i in range(n):
        Qc[i] = 0.0
        Qf[i] = 0.0
    if P[I_CONTACT_E] > 0.0 and n > 1:
        energy, power = contact_forces(y, n, P, Qc)
    if P[I_ROLLING_MU] > 0.0 and n > 0:
        mode = np.empty(n)
        rolling_deriv(t, y, n, P, S, mode, False, np.empty(2 * N), qdd, Qf, A, W, f, B, fb, u)
    return energy, power

@kernel
def deriv(t, y, n, P, S, dy, qdd, A, W, f, B, fb, u):
    N = PHI + n
    accel(t, y, n, P, S, qdd, A, W, f, B, fb, u)
    for i in range(N):
        dy[i] = y[N + i]
        dy[N + i] = qdd[i]

@kernel
def check_state(y, n):
    """OK, NONFINITE or ENVELOPE for the state y."""
    N = PHI + n
    for i in range(2 * N):
        if not math.isfinite(y[i]):
            return NONFINITE
    for i in range(DECK, DECK + 3):
        if abs(y[i]) > MAX_TRANSLATION:
            return ENVELOPE
    for i in range(DECK + 3, PHI):
        if abs(y[i]) > MAX_ANGLE:
            return ENVELOPE
    for i in range(n):
        if abs(y[N + PHI + i]) > MAX_BALL_RATE:
            return ENVELOPE
    return OK

@kernel
def rk4_substep(t, h, y, n, P, S, k1, k2, k3, k4, yt, qdd, A, W, f, B, fb, u):
    """One classical RK4 step of h from (t, y), y updated in place (no state check)."""
    n2 = y.shape[0]
    deriv(t, y, n, P, S, k1, qdd, A, W, f, B, fb, u)
    for i in range(n2):
        yt[i] = y[i] + 0.5 * h * k1[i]
    deriv(t + 0.5 * h, yt, n, P, S, k2, qdd, A, W, f, B, fb, u)
    for i in range(n2):
        yt[i] = y[i] + 0.5 * h * k2[i]
    deriv(t + 0.5 * h, yt, n, P, S, k3, qdd, A, W, f, B, fb, u)
    for i in range(n2):
        yt[i] = y[i] + h * k3[i]
    deriv(t + h, yt, n, P, S, k4, qdd, A, W, f, B, fb, u)
    h6 = h / 6.0
    for i in range(n2):
        y[i] = y[i] + h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])

@kernel
def rk4_frozen(t, h, y0, n, P, S, mode, k1, k2, k3, k4, yt, y, qdd, Qf, A, W, f, B, fb, u):
    """y = one classical RK4 step of h from (t, y0) with the rolling regimes ``mode`` kept
    (k1, the derivative at y0, given)."""
    n2 = y0.shape[0]
    for i in range(n2):
        yt[i] = y0[i] + 0.5 * h * k1[i]
    rolling_deriv(t + 0.5 * h, yt, n, P, S, mode, True, k2, qdd, Qf, A, W, f, B, fb, u)
    for i in range(n2):
        yt[i] = y0[i] + 0.5 * h * k2[i]
    rolling_deriv(t + 0.5 * h, yt, n, P, S, mode, True, k3, qdd, Qf, A, W, f, B, fb, u)
    for i in range(n2):
        yt[i] = y0[i] + h * k3[i]
    rolling_deriv(t + h, yt, n, P, S, mode, True, k4, qdd, Qf, A, W, f, B, fb, u)
    h6 = h / 6.0
    for i in range(n2):
        y[i] = y0[i] + h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])

@kernel
def hermite(s, H, y0, f0, y1, f1, out):
    """out = the cubic Hermite interpolant at s H of a step of H from (y0, f0) to (y1, f1)
    (values and derivatives), 0 <= s <= 1."""
    s2 = s * s
    s3 = s2 * s
    a0 = 2.0 * s3 - 3.0 * s2 + 1.0
    b0 = (s3 - 2.0 * s2 + s) * H
    a1 = 3.0 * s2 - 2.0 * s3
    b1 = (s3 - s2) * H
    for i in range(y0.shape[0]):
        out[i] = a0 * y0[i] + b0 * f0[i] + a1 * y1[i] + b1 * f1[i]

@kernel
def illinois(lo, glo, hi, ghi, side, tau, gt):
    """The bracket [lo, hi] of a root (margins glo >= 0 > ghi) updated with the point (tau,
    gt), and the next estimate (regula falsi with the Illinois halving; bisection where it
    would leave the bracket): (lo, glo, hi, ghi, side, estimate)."""
    if gt >= 0.0:
        lo, glo = tau, gt
        if side == 1:
            ghi *= 0.5
        side = 1
    else:
        hi, ghi = tau, gt
        if side == -1:
            glo *= 0.5
        side = -1
    est = hi - ghi * (hi - lo) / (ghi - glo)
    if not lo < est < hi:
        est = 0.5 * (lo + hi)
    return lo, glo, hi, ghi, side, est

@kernel
def rolling_cache_hit(y, n, S, cache):
    """True when ``cache`` (:func:`rk4_rolling_substep`) holds the regimes and derivative of
    the state y under the spindle profile S (a ramp's time-dependent theta'' never hits)."""
    if cache[2, 0] != 1.0 or S[0] == SPINDLE_RAMP:
        return False
    for i in range(y.shape[0]):
        if cache[0, i] != y[i]:
            return False
    for i in range(S.shape[0]):
        if cache[2, 1 + n + i] != S[i]:
            return False
    return True

@kernel
def rk4_rolling_substep(t, h, y, n, P, S, k1, k2, k3, k4, yt, events, cache,
                        A, W, f, B, fb, u):
    """One RK4 step of h from (t, y) with rolling resistance, switches located; y in place.

    The balls' regimes at the start (:func:`accel_rolling`) are kept over the step (each
    law's smooth extension, so RK4 keeps its order). Where the regimes of the end state
    differ and the switching function there is negative, a regime ended inside the step: its
    instant is located by regula falsi (Illinois) on the RK4 step from the start, to
    SWITCH_TOL h; the step is taken to just past it, the regimes of that state determined,
    and the rest of the step integrated the same way (at most MAX_SWITCHES switches). The
    step's end stays t + h. Row k of ``events`` receives switch k: [its offset from t, the
    regimes after it (n), the state there (2N)]. ``cache`` (3, 2N) carries the end state,
    its derivative and [1, regimes (n), S] to the next step's start
    (:func:`rolling_cache_hit`; zeros: none). Returns the number of switches."""
    n2 = y.shape[0]
    y0 = y.copy()
    qdd = np.empty(n2 // 2)
    Qf = np.empty(n)
    mode = np.empty(n)
    after = np.empty(n)
    if rolling_cache_hit(y0, n, S, cache):
        for i in range(n2):
            k1[i] = cache[1, i]
        for b in range(n):
            mode[b] = cache[2, 1 + b]
    else:
        rolling_deriv(t, y0, n, P, S, mode, False, k1, qdd, Qf, A, W, f, B, fb, u)
    start = 0.0
    switches = 0
    locate = True
    while True:
        rk4_frozen(t + start, h - start, y0, n, P, S, mode, k1, k2, k3, k4, yt, y, qdd, Qf,
                   A, W, f, B, fb, u)
        # the end state's regimes and derivative: the next step's start
        rolling_deriv(t + h, y, n, P, S, after, False, cache[1], qdd, Qf, A, W, f, B, fb, u)
        for i in range(n2):
            cache[0, i] = y[i]
        cache[2, 0] = 1.0
        for b in range(n):
            cache[2, 1 + b] = after[b]
        for i in range(S.shape[0]):
            cache[2, 1 + n + i] = S[i]
        changed = False
        for b in range(n):
            if after[b] != mode[b]:
                changed = True
        if not changed or not locate or switches == MAX_SWITCHES:
            return switches
        H = h - start
        ghi = rolling_deriv(t + h, y, n, P, S, mode, True, k4, qdd, Qf, A, W, f, B, fb, u)
        glo = rolling_deriv(t + start, y0, n, P, S, mode, True, yt, qdd, Qf, A, W, f, B, fb, u)
        if ghi >= 0.0 or glo < 0.0:
            return switches                 # no crossing of this regime's boundary
        # 1. the crossing on the step's cubic Hermite interpolant (one solve per iterate)
        lo, g_lo, hi, g_hi, side = 0.0, glo, H, ghi, 0
        tau = H * glo / (glo - ghi)
        for _ in range(MAX_LOCATE):
            hermite(tau / H, H, y0, k1, y, k4, yt)
            gt = rolling_deriv(t + start + tau, yt, n, P, S, mode, True, k3, qdd, Qf,
                               A, W, f, B, fb, u)
            if abs(gt) <= 1e-3 * MARGIN_TOL:    # (a ball that has just switched has a
                break                           # margin of ~MARGIN_TOL: not a crossing)
            lo, g_lo, hi, g_hi, side, tau = illinois(lo, g_lo, hi, g_hi, side, tau, gt)
            if hi - lo <= SWITCH_TOL * h:
                break
        # 2. secant on RK4 steps from the segment start, from there (the interpolant's local
        # slope first), aimed at the margin -MARGIN_TOL / 2 just past the crossing, until one
        # lands in (-MARGIN_TOL, 0)
        slope = (g_hi - g_lo) / (hi - lo) if hi > lo else 0.0
        if not slope < 0.0:
            slope = (ghi - glo) / H         # the step's secant (ghi < 0 <= glo)
        lo, hi = 0.0, H
        at_hi = False
        t_prev, g_prev = tau, 0.0
        for k in range(MAX_LOCATE):
            rk4_frozen(t + start, tau, y0, n, P, S, mode, k1, k2, k3, k4, yt, y, qdd, Qf,
                       A, W, f, B, fb, u)
            gt = rolling_deriv(t + start + tau, y, n, P, S, mode, True, yt, qdd, Qf,
                               A, W, f, B, fb, u)
            at_hi = gt < 0.0
            if at_hi:
                hi = tau
            else:
                lo = tau
            if (at_hi and gt > -MARGIN_TOL) or hi - lo <= SWITCH_TOL * h:
                break
            if k > 0 and tau != t_prev and (gt - g_prev) / (tau - t_prev) < 0.0:
                slope = (gt - g_prev) / (tau - t_prev)
            t_prev, g_prev = tau, gt
            tau -= (gt + 0.5 * MARGIN_TOL) / slope
            if not lo < tau < hi:
                tau = 0.5 * (lo + hi)
        if not at_hi:
            rk4_frozen(t + start, hi, y0, n, P, S, mode, k1, k2, k3, k4, yt, y, qdd, Qf,
                       A, W, f, B, fb, u)
        start += hi
        for i in range(n2):
            y0[i] = y[i]
        rolling_deriv(t + start, y0, n, P, S, after, False, k1, qdd, Qf, A, W, f, B, fb, u)
        changed = False
        for b in range(n):
            if after[b] != mode[b]:
                changed = True
            mode[b] = after[b]
        if changed:
            events[switches, 0] = start
            for b in range(n):
                events[switches, 1 + b] = mode[b]
            for i in range(n2):
                events[switches, 1 + n + i] = y0[i]
            switches += 1
        else:
            locate = False      # the state past the crossing keeps its regimes: finish with them

@kernel
def rk4_substeps(t, dt, sub, y, n, P, S, k1, k2, k3, k4, yt, qdd, A, W, f, B, fb, u):
    """``sub`` RK4 sub-steps of dt / sub of the whole system from (t, y), y in place."""
    h = dt / sub
    for j in range(sub):
        rk4_substep(t + j * h, h, y, n, P, S, k1, k2, k3, k4, yt, qdd, A, W, f, B, fb, u)

@kernel
def rk4_step(t, dt, y, n, P, S, k1, k2, k3, k4, yt, ysave, qdd, A, W, f, B, fb, u):
    """:func:`rk4_step_located` without the count of rolling switches and without a cache
    from the previous step: (status, sub-steps)."""
    n2 = y.shape[0]
    if P[I_ROLLING_MU] > 0.0:
        cache = np.zeros((3, n2))
    else:
        cache = ysave.reshape((1, n2))      # not used: no allocation on the paper's path
    status, sub, _ = rk4_step_located(t, dt, y, n, P, S, k1, k2, k3, k4, yt, ysave, qdd,
                                      A, W, f, B, fb, u, cache)
    return status, sub

@kernel
def rk4_step_located(t, dt, y, n, P, S, k1, k2, k3, k4, yt, ysave, qdd, A, W, f, B, fb, u,
                     cache):
    """One step of dt from (t, y), y updated in place: one classical RK4 step, or, while
    balls touch (issue 12), sub-steps of dt / :func:`contact_substeps`: the multirate step
    :func:`mis_contact_step` (only the contact forces sub-stepped, :func:`mis_substeps`
    times; :func:`contact_step`), or, in torque mode and with rolling resistance, RK4
    sub-steps of the whole system (in an impact MIS_IMPACT_REFINE times as many, as the
    multirate step's). A step with a contact resolved as resting, in one RK4 step or in
    sub-steps, is taken again when :func:`retake_substeps` says so (not with rolling
    resistance); with rolling resistance each (sub)step locates its regime switches
    (:func:`rk4_rolling_substep`, ``cache`` (3, 2N) carried from step to step). k1..k4, yt
    and ysave are stage buffers of shape (2N,), the rest the solver scratch of :func:`accel`.
    Returns (status, sub-steps (the multirate step's fast ones), switches): the
    :func:`check_state` status of the new state (when it is not OK, y is put back to its
    value before the step)."""
    n2 = y.shape[0]
    for i in range(n2):
        ysave[i] = y[i]
    sub = 1
    impact = False
    resting = False
    if P[I_CONTACT_E] > 0.0 and n > 1:
        sub, impact, resting = contact_regimes(y, n, P, dt, False)
    switches = 0
    if P[I_ROLLING_MU] > 0.0 and n > 0 and S[0] != SPINDLE_TORQUE:
        events = np.empty((MAX_SWITCHES, 1 + n + n2))
        h = dt / sub
        for j in range(sub):
            switches += rk4_rolling_substep(t + j * h, h, y, n, P, S, k1, k2, k3, k4, yt,
                                            events, cache, A, W, f, B, fb, u)
    elif sub == 1 and not impact and not resting:
        rk4_substep(t, dt, y, n, P, S, k1, k2, k3, k4, yt, qdd, A, W, f, B, fb, u)
    elif sub > 1 and S[0] != SPINDLE_TORQUE:
        sub = contact_step(t, dt, y, ysave, n, P, S, sub, impact, np.empty((0, n2)), qdd, A, W,
                           f, B, fb, u)
    else:
        # whole-system RK4 sub-steps (torque mode), or one RK4 step (a contact resolved in
        # one step); both taken again when a resting contact did not rest
        if impact:
            sub = int(math.ceil(sub * MIS_IMPACT_REFINE))
        rk4_substeps(t, dt, sub, y, n, P, S, k1, k2, k3, k4, yt, qdd, A, W, f, B, fb, u)
        forced = retake_substeps(ysave, y, n, P, dt, impact, sub, MIS_IMPACT_REFINE)
        if forced > 0:
            for i in range(n2):
                y[i] = ysave[i]
            if S[0] == SPINDLE_TORQUE:
                sub = forced
                rk4_substeps(t, dt, sub, y, n, P, S, k1, k2, k3, k4, yt, qdd, A, W, f, B, fb,
                             u)
            else:
                sub = mis_contact_step(t, dt, y, n, P, S, forced, np.empty((0, n2)), qdd, A,
                                       W, f, B, fb, u)
    status = check_state(y, n)
    if status != OK:
        for i in range(n2):
            y[i] = ysave[i]
    return status, sub, switches

@kernel
def rk4_advance(y, t0, dt, step0, nsteps, n, P, S, work):
    """Advance y in place by nsteps classical RK4 steps of dt from t = (step0) dt + t0.

    Time is recomputed from the integer step count at every step (no accumulated drift).
    ``work`` : ndarray, shape (6, 2N) of stage buffers, plus the solver scratch that
    :func:`make_work` allocates. Returns (steps_done, status); on a bad state the
    state of the last good step is kept.
    """
    N = PHI + n
    k1, k2, k3, k4, yt, ysave = work[0], work[1], work[2], work[3], work[4], work[5]
    qdd = np.empty(N)
    A, W, f, B, fb, u = solver_scratch(n)
    cache = work[7:10] if work.shape[0] >= 10 else np.zeros((3, 2 * N))
    for s in range(nsteps):
        t = t0 + (step0 + s) * dt
        status, sub, switches = rk4_step_located(t, dt, y, n, P, S, k1, k2, k3, k4, yt, ysave,
                                                 qdd, A, W, f, B, fb, u, cache)
        if sub > 1 and work.shape[0] > 6:   # contact statistics (issue 12)
            work[6, 0] += 1.0
            work[6, 1] = max(work[6, 1], float(sub))
            work[6, 2] += float(sub)
        if switches > 0 and work.shape[0] > 6:     # located rolling switches
            work[6, 3] += float(switches)
        if status != OK:
            return s, status
    return nsteps, OK

@kernel
def rk4_trajectory(y, t0, dt, step0, nsteps, every, n, P, S, work, out):
    """Like rk4_advance, storing y after every ``every`` steps into ``out`` rows.

    Returns (steps_done, rows_written, status).
    """
    rows = 0
    done = 0
    while done < nsteps:
        chunk = min(every, nsteps - done)
        got, status = rk4_advance(y, t0, dt, step0 + done, chunk, n, P, S, work)
        done += got
        if status != OK:
            return done, rows, status
        if chunk == every:
            for i in range(y.shape[0]):
                out[rows, i] = y[i]
            rows += 1
    return done, rows, OK


JIT, PY = kernel.build()
"""JIT: compiled kernels (numba), or the Python twin where numba is unavailable; PY: the
pure-Python twin of every kernel, the same source run by the interpreter."""


def make_work(n: int) -> np.ndarray:
    """Stage buffers for :func:`rk4_advance`: shape (10, 2 (7 + n)); row 6 counts the
    steps refined for contact ([6, 0]), the most sub-steps of one step ([6, 1]), the
    sub-steps of all refined steps ([6, 2]) and the located rolling switches ([6, 3]); rows
    7-9 carry the rolling regimes from step to step (:func:`rk4_rolling_substep`)."""
    return np.zeros((10, 2 * (PHI + n)))


def pack_params(params) -> np.ndarray:
    """DriveParams -> P array in :data:`PARAM_ORDER`."""
    return np.array([float(getattr(params, name)) for name in PARAM_ORDER])

"""Packed inputs and scratch of the model's kernels, with a name for every index.

The kernels take plain float arrays (no Python objects), so each packed array has a layout:

``P`` : ndarray, shape (N_PARAMS,)
    Drive parameters in the order of :data:`PARAM_ORDER` (SI), :func:`pack_params`; entry
    ``P[P_R]`` is the race radius R, and so on (one ``P_<name>`` per parameter).
``S`` : ndarray, shape (N_SPINDLE,) or (N_SPINDLE_TORQUE,)
    Spindle profile. ``S[S_MODE]`` = SPINDLE_CONSTANT (theta'' = 0, the paper's case),
    SPINDLE_MOTOR (omega_cmd tracked as a first-order lag of time constant tau limited to
    +-max_accel), SPINDLE_RAMP (theta'' = ramp_accel for t0 <= t < t1, else 0) or
    SPINDLE_TORQUE (theta free, driven by the current-commanded motor of docs/torque_mode.md).
``work`` : ndarray, shape (N_WORK_ROWS, 2N)
    Buffers of :func:`abb_ros.model.dynamics.kernels.stepper.advance`, :func:`make_work`.

State ``y = [q, q']`` with ``q = [theta, X, Y, Z, alpha, beta, gamma, phi_1..phi_n]``: the
kernels index it with the offsets of :mod:`abb_ros.model.dynamics.state` (DECK, PHI; N = PHI + n).

Scratch passed between kernels is grouped in named tuples (numba compiles their fields as
typed members): :class:`Solver`, the linear system of one evaluation of q'', and
:class:`Stages`, the stage buffers of one RK4 step.

Every kernel is registered with the one :data:`kernel` set, so that compiled kernels call
compiled kernels; :mod:`abb_ros.model.dynamics.kernels` builds it.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from abb_ros.model.dynamics.state import PHI
from abb_ros.model.jit import KernelSet

kernel = KernelSet(nogil=True, error_model='numpy')
"""Marks the kernels of the model (compiled where numba is available)."""

PARAM_ORDER = ('a', 'b', 'd', 'R', 'M_P', 'M', 'm', 'J_Px', 'J_Py', 'J_Pz', 'J_x', 'J_y', 'J_z',
               'k', 'c', 'D', 'eps', 'n',
               'r_ball', 'contact_E', 'contact_nu', 'contact_damping', 'rolling_mu',
               'rolling_stick_rate', 'ball_rotation', 'z_P', 'z_G', 'z_B', 'tau', 'psi_tau')
N_PARAMS = len(PARAM_ORDER)
(P_A, P_B, P_D, P_R, P_M_P, P_M, P_m, P_J_Px, P_J_Py, P_J_Pz, P_J_x, P_J_y, P_J_z,
 P_K, P_C, P_DRAG, P_EPS, P_N,
 P_R_BALL, P_CONTACT_E, P_CONTACT_NU, P_CONTACT_DAMPING, P_ROLLING_MU,
 P_STICK_RATE, P_BALL_ROTATION, P_Z_P, P_Z_G, P_Z_B, P_TAU, P_PSI_TAU) = range(N_PARAMS)
"""Index in P of each entry of PARAM_ORDER (P_DRAG: the balls' drag D, P_K, P_C: k, c)."""

N_SPINDLE = 7
SPINDLE_CONSTANT, SPINDLE_MOTOR, SPINDLE_RAMP = 0, 1, 2
SPINDLE_TORQUE = 3
N_SPINDLE_TORQUE = 9
S_MODE = 0
"""Index in S of the profile's mode (every profile)."""
S_OMEGA_CMD, S_MAX_ACCEL, S_TAU, S_T0, S_T1, S_RAMP_ACCEL = 1, 2, 3, 4, 5, 6
"""Speed profiles: [mode, omega_cmd, max_accel, tau, t0, t1, ramp_accel]."""
S_I_CMD, S_K_T, S_R_W, S_I_MAX, S_B_V, S_T_C, S_OMEGA_C, S_V_S = 1, 2, 3, 4, 5, 6, 7, 8
"""Torque mode: [mode, i_cmd, K_t, R_w, I_max, b_v, T_c, omega_c, V_s]."""

MAX_TRANSLATION = 0.02
"""Envelope of sane states: deck translations [m] (docs/architecture.md, Errors) ..."""
MAX_ANGLE = 0.3
"""... deck angles [rad] ..."""
MAX_BALL_RATE = 1.0e5
"""... and ball rates [rad/s]; outside it the small-angle model is meaningless."""

OK, NONFINITE, ENVELOPE = 0, 1, 2
"""Status of a state (:func:`abb_ros.model.dynamics.kernels.stepper.check_state`)."""

W_K1, W_K2, W_K3, W_K4, W_YT, W_YSAVE = 0, 1, 2, 3, 4, 5
"""Rows of ``work``: the stage buffers of :class:`Stages` ..."""
W_STATS = 6
"""... the contact and rolling statistics (columns STAT_*) ..."""
W_CACHE = 7
"""... and rows W_CACHE to W_CACHE + 2: the rolling cache carried from step to step
(rows CACHE_* of :func:`abb_ros.model.dynamics.kernels.rolling_events.rolling_substep`)."""
N_WORK_ROWS = W_CACHE + 3
STAT_REFINED, STAT_MOST_SUBSTEPS, STAT_SUBSTEPS, STAT_SWITCHES = 0, 1, 2, 3
"""Columns of work[W_STATS]: steps refined for contact, the most sub-steps of one step, the
sub-steps of all refined steps, the located rolling switches."""
CACHE_STATE, CACHE_DERIV, CACHE_TAG = 0, 1, 2
"""Rows of the rolling cache: the end state, its derivative, [1, regimes (n), S]."""

Solver = namedtuple('Solver', ['qdd', 'A', 'W', 'f', 'B', 'fb', 'u', 'Qf'])
"""Scratch of one evaluation of q'' (:func:`solver_scratch`): q'' (N), the deck rows
A u + W phi'' = f (6 x 6, 6 x n, 6), the ball rows B u + m R^2 phi'' = fb (n x 6, n), the
deck accelerations u (6) and the balls' rolling-resistance forces Qf (n)."""

Stages = namedtuple('Stages', ['k1', 'k2', 'k3', 'k4', 'yt', 'ysave'])
"""Buffers (2N each) of one RK4 step: the stage derivatives, the stage state and the state
before the step."""


@kernel
def solver_scratch(n):
    """Return the :class:`Solver` scratch for n balls (its arrays uninitialised)."""
    nb = max(n, 1)
    return Solver(np.empty(PHI + n), np.empty((6, 6)), np.empty((6, nb)), np.empty(6),
                  np.empty((nb, 6)), np.empty(nb), np.empty(6), np.empty(nb))


@kernel
def work_stages(work):
    """Return the :class:`Stages` held in the rows W_K1..W_YSAVE of ``work``."""
    return Stages(work[W_K1], work[W_K2], work[W_K3], work[W_K4], work[W_YT], work[W_YSAVE])


def stage_buffers(n: int) -> Stages:
    """Return new :class:`Stages` for n balls (zeros)."""
    return Stages(*(np.zeros(2 * (PHI + n)) for _ in Stages._fields))


def make_work(n: int) -> np.ndarray:
    """Return the zeroed ``work`` buffers of :func:`~.kernels.stepper.advance`.

    Shape (N_WORK_ROWS, 2 (7 + n)): the rows are named W_* (stage buffers, statistics,
    rolling cache).
    """
    return np.zeros((N_WORK_ROWS, 2 * (PHI + n)))


def pack_params(params) -> np.ndarray:
    """Return the P array of a DriveParams, in :data:`PARAM_ORDER`."""
    return np.array([float(getattr(params, name)) for name in PARAM_ORDER])

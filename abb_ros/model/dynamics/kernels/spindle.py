"""The spindle's drive: theta'' of a speed profile, and the current-commanded motor's torque.

Speed-driven profiles (SPINDLE_CONSTANT, SPINDLE_MOTOR, SPINDLE_RAMP) prescribe theta''
(:func:`spindle_accel`; constant speed, theta'' = 0, is the paper's case). In torque mode
(SPINDLE_TORQUE, docs/torque_mode.md) theta is free and driven by Q_theta =
:func:`spindle_torque` of a DC/BLDC motor whose winding current is :func:`motor_current`.
S holds the profile (layout: the S_* indices of :mod:`abb_ros.model.dynamics.kernels.layout`).
"""

from __future__ import annotations

import math

from abb_ros.model.dynamics.kernels.layout import (
    S_B_V,
    S_I_CMD,
    S_I_MAX,
    S_K_T,
    S_MAX_ACCEL,
    S_MODE,
    S_OMEGA_C,
    S_OMEGA_CMD,
    S_R_W,
    S_RAMP_ACCEL,
    S_T0,
    S_T1,
    S_T_C,
    S_TAU,
    S_V_S,
    SPINDLE_MOTOR,
    SPINDLE_RAMP,
    kernel,
)


@kernel
def spindle_accel(t, omega, S):
    """Return theta'' [rad/s^2] of the speed profile S at time t and speed omega."""
    mode = S[S_MODE]
    if mode == SPINDLE_MOTOR:
        acc = (S[S_OMEGA_CMD] - omega) / S[S_TAU]
        if acc > S[S_MAX_ACCEL]:
            acc = S[S_MAX_ACCEL]
        elif acc < -S[S_MAX_ACCEL]:
            acc = -S[S_MAX_ACCEL]
        return acc
    if mode == SPINDLE_RAMP:
        if S[S_T0] <= t < S[S_T1]:
            return S[S_RAMP_ACCEL]
        return 0.0
    return 0.0


@kernel
def motor_current(omega, S):
    """Return the winding current [A] of the current-commanded drive (S of torque mode).

    The command, limited by the supply voltage (R_w i + K_t omega within +-V_s, back-EMF
    constant K_e = K_t in SI), then clipped to +-I_max (inductance neglected: the current
    loop is much faster than the mechanics).
    """
    i = S[S_I_CMD]
    K_t, R_w, i_max, V_s = S[S_K_T], S[S_R_W], S[S_I_MAX], S[S_V_S]
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
    """Return Q_theta [N m]: the motor torque K_t i minus the bearing friction.

    Friction b_v omega + T_c tanh(omega / omega_c) (Coulomb friction smoothed over omega_c).
    """
    return (S[S_K_T] * motor_current(omega, S) - S[S_B_V] * omega
            - S[S_T_C] * math.tanh(omega / S[S_OMEGA_C]))

"""The spindle: a prescribed speed profile, or a free spindle driven by a motor's torque.

The spindle speed is an input of the model: :class:`ConstantSpeed` (the paper's case),
:class:`Ramp` (constant angular acceleration over an interval) or :class:`SpindleMotor` (tracks
a commanded speed as a first-order lag with an acceleration limit, as a speed-controlled
spindle motor does); or the spindle is free and driven by torque: :class:`TorqueMotor` (a
current-commanded DC/BLDC motor, docs/torque_mode.md). Each packs itself into the profile
array ``S`` of the kernels (:mod:`abb_ros.model.dynamics.kernels.layout`); the command of
``pack`` is the speed [rad/s] or, for :class:`TorqueMotor`, the winding current [A].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from abb_ros.model.dynamics import kernels
from abb_ros.model.parameters.params import ParamError
from abb_ros.model.parameters.plant_spec import MOTOR_DEFAULTS

__all__ = ['ConstantSpeed', 'Ramp', 'SpindleMotor', 'TorqueMotor']


@dataclass(frozen=True)
class ConstantSpeed:
    """theta'' = 0: the paper's constant omega."""

    def pack(self, omega_cmd: float = 0.0) -> np.ndarray:
        """Return the packed profile S (:mod:`abb_ros.model.dynamics.kernels.layout`)."""
        return np.array([kernels.SPINDLE_CONSTANT, omega_cmd, 0, 1, 0, 0, 0], dtype=float)


@dataclass(frozen=True)
class Ramp:
    """theta'' = accel [rad/s^2] for t0 <= t < t1 [s], zero otherwise."""

    t0: float
    t1: float
    accel: float

    def pack(self, omega_cmd: float = 0.0) -> np.ndarray:
        """Return the packed profile S (:mod:`abb_ros.model.dynamics.kernels.layout`)."""
        return np.array([kernels.SPINDLE_RAMP, omega_cmd, 0, 1, self.t0, self.t1, self.accel],
                        dtype=float)


@dataclass(frozen=True)
class SpindleMotor:
    """Speed-controlled spindle: theta'' = clip((omega_cmd - omega)/tau, +-max_accel).

    max_accel [rad/s^2] > 0, tau [s] > 0.
    """

    max_accel: float = 1000.0
    tau: float = 0.05

    def __post_init__(self):
        for name, value in (('max_accel', self.max_accel), ('tau', self.tau)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ParamError(f'spindle.{name}', value, '(0, inf)')

    def pack(self, omega_cmd: float = 0.0) -> np.ndarray:
        """Return the packed profile S (:mod:`abb_ros.model.dynamics.kernels.layout`)."""
        return np.array([kernels.SPINDLE_MOTOR, omega_cmd, self.max_accel, self.tau, 0, 0, 0],
                        dtype=float)


@dataclass(frozen=True)
class TorqueMotor:
    """Free spindle driven by a current-commanded DC/BLDC motor (docs/torque_mode.md).

    The command of :meth:`pack` is the winding current [A]. K_t [N m/A] (= K_e [V s/rad]),
    R_w [ohm], I_max [A], V_s [V] > 0; bearing friction b_v [N m s] and T_c [N m] >= 0,
    smoothed over omega_c [rad/s] > 0.
    """

    K_t: float = MOTOR_DEFAULTS['torque_constant']
    R_w: float = MOTOR_DEFAULTS['resistance']
    I_max: float = MOTOR_DEFAULTS['current_limit']
    b_v: float = MOTOR_DEFAULTS['viscous_friction']
    T_c: float = MOTOR_DEFAULTS['coulomb_friction']
    omega_c: float = MOTOR_DEFAULTS['friction_smoothing']
    V_s: float = MOTOR_DEFAULTS['voltage_limit']

    FIELDS = dict(K_t='torque_constant', R_w='resistance', I_max='current_limit',
                  b_v='viscous_friction', T_c='coulomb_friction', omega_c='friction_smoothing',
                  V_s='voltage_limit')
    """Field -> parameter name (``motor.<name>``, plant_spec.MOTOR_DEFAULTS)."""

    @classmethod
    def from_values(cls, values) -> 'TorqueMotor':
        """From {``motor.<name>``: value}; missing names take their defaults."""
        return cls(**{f: float(values.get('motor.' + name, MOTOR_DEFAULTS[name]))
                      for f, name in cls.FIELDS.items()})

    def __post_init__(self):
        for name in ('K_t', 'R_w', 'I_max', 'b_v', 'T_c', 'omega_c', 'V_s'):
            value = getattr(self, name)
            positive = name not in ('b_v', 'T_c')
            if not (isinstance(value, (int, float)) and math.isfinite(value)
                    and (value > 0 or (not positive and value == 0))):
                raise ParamError(f'motor.{self.FIELDS[name]}', value,
                                 '(0, inf)' if positive else '[0, inf)')

    def pack(self, current_cmd: float = 0.0) -> np.ndarray:
        """Return the packed profile S of torque mode (:mod:`~.dynamics.kernels.layout`)."""
        return np.array([kernels.SPINDLE_TORQUE, current_cmd, self.K_t, self.R_w, self.I_max,
                         self.b_v, self.T_c, self.omega_c, self.V_s], dtype=float)

    def current(self, omega: float, current_cmd: float) -> float:
        """Winding current [A] at speed omega for the command (limits applied)."""
        return float(kernels.PY.motor_current(float(omega), self.pack(current_cmd)))

"""Speed loop of a torque-mode drive (docs/torque_mode.md).

The winding current that makes the free spindle follow a speed reference.

Pure and stepwise (tested without ROS); the example controller ``spin_controller`` runs it in
torque mode on the reference of :class:`abb_ros.nodes.spin_controller.run_up.RunUp`. With the
rotor's equation of motion seen by the motor, (J_z + I_r) omega' = K_t i - b_v omega - T_c
tanh(omega / omega_c) + load (the theta row, the balls and the deck in the load), the current

    i = [(J_z + I_r) omega_ref' + b_v omega + T_c tanh(omega / omega_c)] / K_t
        + k_p e + k_i int(e),    e = omega_ref - omega,

is the feedforward of the reference's acceleration and of the friction estimate plus a PI on
the speed error, clipped to what the drive delivers at omega (+-I_max and the supply,
:meth:`abb_ros.model.dynamics.spindle.TorqueMotor.current`). The gains place the crossover of the
loop at ``bandwidth`` wc: k_p = (J_z + I_r) wc / K_t [A s/rad], k_i = k_p wc / 4 [A/rad] (the
PI zero a quarter of the crossover: about 76 deg of phase margin on the rigid rotor).
Anti-windup by conditional integration: while the current is clipped, the integral does not
grow in the direction of the clip.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from abb_ros.model.dynamics.spindle import TorqueMotor
from abb_ros.model.parameters.params import DriveParams

__all__ = ['rotor_inertia', 'SpeedLoop', 'PI_ZERO_RATIO']

PI_ZERO_RATIO = 0.25
"""The PI zero k_i / k_p as a fraction of the crossover wc."""


def rotor_inertia(drive: DriveParams) -> float:
    """Return J_z + I_r [kg m^2], the inertia the motor accelerates; I_r = M eps^2 + n m R^2.

    The coefficient of theta'' in the theta row (docs/torque_mode.md); a second race adds its
    race2.n m_2 R_2^2.
    """
    return drive.J_z + drive.M * drive.eps ** 2 + sum(m * R ** 2 for m, R, _ in drive.per_ball())


@dataclass
class SpeedLoop:
    """Current command [A] from the speed reference and the measured speed (module doc).

    ``inertia`` [kg m^2] (:func:`rotor_inertia`), ``bandwidth`` wc [rad/s]; ``integral`` [A]
    is the state.
    """

    motor: TorqueMotor
    inertia: float
    bandwidth: float
    integral: float = 0.0

    @property
    def kp(self) -> float:
        """Proportional gain [A s/rad]."""
        return self.inertia * self.bandwidth / self.motor.K_t

    @property
    def ki(self) -> float:
        """Integral gain [A/rad]."""
        return self.kp * PI_ZERO_RATIO * self.bandwidth

    def limits(self, omega: float) -> tuple[float, float]:
        """Return the current range [A] the drive delivers at omega [rad/s]."""
        return self.motor.current(omega, -math.inf), self.motor.current(omega, math.inf)

    def friction(self, omega: float) -> float:
        """Estimate the bearing friction b_v omega + T_c tanh(omega / omega_c) [N m]."""
        m = self.motor
        return m.b_v * omega + m.T_c * math.tanh(omega / m.omega_c)

    def feedforward(self, alpha_ref: float, omega: float) -> float:
        """Return the feedforward current [(J_z + I_r) alpha_ref + friction(omega)] / K_t [A]."""
        return (self.inertia * alpha_ref + self.friction(omega)) / self.motor.K_t

    def step(self, omega_ref: float, alpha_ref: float, omega: float, dt: float) -> float:
        """Return the current [A] to hold over the next dt [s].

        For the reference omega_ref [rad/s] (accelerating at alpha_ref [rad/s^2]) at the
        measured speed omega [rad/s].
        """
        error = omega_ref - omega
        lo, hi = self.limits(omega)
        base = self.feedforward(alpha_ref, omega) + self.kp * error
        integral = self.integral + self.ki * error * dt
        wanted = base + integral
        if not ((wanted > hi and error > 0.0) or (wanted < lo and error < 0.0)):
            self.integral = integral
        return min(max(base + self.integral, lo), hi)

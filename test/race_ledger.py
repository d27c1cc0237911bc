"""Two colliding balls on a clamped race and the race's energy ledger (tests and figures).

The clamped race itself is :func:`abb_ros.model.parameters.ball_materials.clamped_race`; the
ledger checks the contact and rolling kernels against energy conservation
(test/model/dynamics/kernels/test_contact_rolling.py, scripts/make_ball_model_figures.py).
"""

import numpy as np

from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.spindle import ConstantSpeed
from abb_ros.model.parameters.params import DriveParams


def collision_state(params: DriveParams, omega: float, gap: float, speed: float):
    """Return a state of two balls about to collide.

    Ball 1 at phi = 0 moving at ``speed`` [m/s] towards ball 2, at rest ``gap`` [m] short of
    contact; deck at rest at the origin; spindle at omega [rad/s].
    """
    sep = params.contact_separation + gap / params.R
    y = initial_state(params, omega, phi0=[0.0, sep], deck0=(0.0,) * 6)
    y[7 + params.n + 7] = speed / params.R
    return y


def simpson(y, dx: float) -> float:
    """Composite Simpson over an odd number of equally spaced samples."""
    if len(y) % 2 != 1:
        raise ValueError('Simpson needs an odd number of samples')
    return dx / 3 * (y[0] + y[-1] + 4 * y[1:-1:2].sum() + 2 * y[2:-1:2].sum())


def race_energy_ledger(params: DriveParams, omega: float, ys, dt: float) -> dict:
    """Return the energy bookkeeping of states ``ys`` (every dt) on a clamped race.

    At constant spindle speed omega: cumulative arrays of the spindle's input work, the balls'
    kinetic and contact potential energy changes, the dissipated energy (drag, contact damping,
    rolling) and the residual (input - kinetic - potential - dissipated), by Simpson's rule per
    pair of steps.

    The spindle torque is theta's row of Lagrange's equations; on a clamped race with theta'' =
    0 it is d/dt sum m_eff R^2 (theta' + phi_i') (spin terms included: J_b Omega_i), so the
    input work is omega times the change of that angular momentum.
    """
    n, N = params.n, 7 + params.n
    mR2 = params.m * params.R ** 2
    Jb = 0.4 * params.m * params.r_ball ** 2 * params.ball_rotation
    Rr = params.R / params.r_ball
    P = kernels.pack_params(params)
    S = ConstantSpeed().pack(omega)
    Qc, Qf = np.empty(n), np.empty(n)
    V = np.empty(len(ys))
    power = np.empty(len(ys))
    for k, y in enumerate(ys):
        V[k], contact_power = kernels.JIT.ball_forces(k * dt, y, n, P, S, Qc, Qf)
        rates = y[N + 7:]
        power[k] = params.D * (rates ** 2).sum() + contact_power - (Qf * rates).sum()
    rates = ys[:, N + 7:]
    spin = omega - Rr * rates                       # the balls' spin about z (rolling)
    T = 0.5 * (mR2 * (omega + rates) ** 2 + Jb * spin ** 2).sum(axis=1)
    L = (mR2 * (omega + rates) + Jb * spin).sum(axis=1)     # dT/dtheta'
    dissipated = np.concatenate([[0.0], np.cumsum(
        [simpson(power[i:i + 3], dt) for i in range(0, len(ys) - 2, 2)])])
    idx = np.arange(0, len(ys), 2)
    w_in = omega * (L[idx] - L[0])
    kinetic = T[idx] - T[0]
    potential = V[idx] - V[0]
    return dict(t=idx * dt, input=w_in, kinetic=kinetic, potential=potential,
                dissipated=dissipated, residual=w_in - kinetic - potential - dissipated)

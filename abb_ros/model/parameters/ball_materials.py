"""Steel balls of finite size: material presets, a clamped race, and its energy ledger.

The terms themselves live in :mod:`abb_ros.model.dynamics.kernels`
(``ball_size.add_ball_rotation``, ``contact.contact_forces``, ``rolling_resistance.accel_rolling``,
``contact_steps.contact_substeps``) and are switched on by the
DriveParams fields ``r_ball``, ``contact_E``, ``contact_nu``, ``contact_damping``,
``rolling_mu``, ``rolling_stick_rate`` and ``ball_rotation`` (all zero: the paper's model).
docs/ball_size_contact_rolling.md states the laws, the assumptions and the measurements.
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.parameters.params import DriveParams

__all__ = ['STEEL_DENSITY', 'STEEL_E', 'STEEL_NU', 'steel_ball_radius', 'with_steel_balls',
           'HEAVY', 'clamped_race', 'collision_state', 'simpson', 'race_energy_ledger']

STEEL_DENSITY = 7850.0
"""Density of bearing steel [kg/m^3]."""
STEEL_E = 2.0e11
"""Young's modulus of bearing steel [Pa]."""
STEEL_NU = 0.3
"""Poisson's ratio of bearing steel."""


def steel_ball_radius(m: float) -> float:
    """Radius [m] of a solid steel ball of mass m [kg]: (3 m / (4 pi rho))^(1/3)."""
    return (3.0 * m / (4.0 * math.pi * STEEL_DENSITY)) ** (1.0 / 3.0)


def with_steel_balls(params: DriveParams, contact: bool = True, rolling_mu: float = 0.0,
                     rotation: bool = False, contact_damping: float = 0.0) -> DriveParams:
    """Return ``params`` with solid steel balls of its mass m.

    Radius from the density, Hertzian contact (if ``contact``), rolling resistance
    ``rolling_mu`` [m], rolling-ball spin inertia (if ``rotation``).
    """
    return params.replace(r_ball=steel_ball_radius(params.m),
                          contact_E=STEEL_E if contact else 0.0, contact_nu=STEEL_NU,
                          contact_damping=contact_damping, rolling_mu=rolling_mu,
                          ball_rotation=int(rotation))


HEAVY = 1e9
"""Mass [kg] and inertia [kg m^2] of an immovable deck (:func:`clamped_race`)."""


def clamped_race(n: int = 2, m: float = 0.78e-3, **changes) -> DriveParams:
    """Return the parameters of steel balls on a race whose deck cannot move.

    Deck mass and inertias HEAVY, rotor without eccentricity and without drag unless given.
    The balls' forces move the deck by
    ~1e-13 of their own accelerations ("deck coupling absent"), so the balls run on a rigid
    race spinning at the spindle speed; the rotor keeps its inertia (a 1e9 J_z would turn the
    deck by the motor's reaction torque).
    """
    base = dict(n=n, m=m, eps=0.0, D=0.0, M_P=HEAVY, J_Px=HEAVY, J_Py=HEAVY, J_Pz=HEAVY,
                r_ball=steel_ball_radius(m), contact_E=STEEL_E, contact_nu=STEEL_NU)
    base.update(changes)
    return DriveParams(**base)


def collision_state(params: DriveParams, omega: float, gap: float, speed: float):
    """Return a state of two balls about to collide.

    Ball 1 at phi = 0 moving at ``speed`` [m/s] towards ball 2, at rest ``gap`` [m] short of
    contact; deck at rest at the origin; spindle at omega [rad/s].
    """
    from abb_ros.model.dynamics.integrate import initial_state
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
    from abb_ros.model.dynamics import kernels
    from abb_ros.model.dynamics.integrate import ConstantSpeed
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

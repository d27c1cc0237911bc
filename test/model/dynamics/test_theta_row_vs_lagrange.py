"""The free-theta equation of torque mode against Lagrange's equation for theta.

The free-theta equation of torque mode (kernels.torque.theta_row) against Lagrange's equation
for theta derived from the energies T, V, F (test/lagrange_sympy.py, theta_expression).

With theta free, Eq. (17) for theta reads d/dt dT/dtheta' - dT/dtheta + dV/dtheta + dF/dtheta' =
Q_theta (the motor torque less the bearing friction: an internal torque between rotor and deck, so
it does work on the relative angle theta only). abb_ros keeps it to first order in the deck
coordinates, like Eqs. (18)-(24). Normalisation: the rotation scale M eps R omega^2.
"""

import lagrange_sympy as L
import numpy as np
import pytest
from test_equations_vs_lagrange import ROUND_OFF, at_scale, scales, states

from abb_ros.model.dynamics import equations, kernels
from abb_ros.model.dynamics.spindle import TorqueMotor

S0 = 1e-3
"""Deck scale of the order test, as in test_equations_vs_lagrange."""


def kernel_theta_residual(params, y, qdd):
    """LHS of the kernel's theta row at (y, qdd): a . u + I_th theta'' + m R^2 sum phi''."""
    n = params.n
    a = np.empty(6)
    col = np.empty(6)
    I_th = kernels.PY.theta_row(y, n, kernels.pack_params(params), a, col)
    mR2 = params.m * params.R ** 2
    return a @ qdd[1:7] + I_th * qdd[0] + mR2 * np.sum(qdd[7:])


def theta_scale(params, omega):
    """Return the scale of the theta row's terms, M eps R omega^2 [N m]."""
    return params.M * params.eps * params.R * omega ** 2


@pytest.mark.parametrize('n', [1, 2, 3])
def test_theta_row_is_the_first_order_lagrange_equation_for_theta(n):
    """At random states (theta'' up to 2000 rad/s^2, deck scale 0.05: both sides are first-order
    forms, equal for any s) the kernel's theta row equals the first-order expansion of Lagrange's
    theta equation to round-off.
    """
    for params, (y, qdd, deck) in states(n, seed=400):
        y, qdd = at_scale(y, qdd, deck, 0.05)
        _, first = L.theta_residuals(params, y, qdd)
        err = (kernel_theta_residual(params, y, qdd) - first) / theta_scale(params, y[7 + n])
        assert abs(err) < ROUND_OFF, err


@pytest.mark.parametrize('n', [1, 2])
def test_theta_row_differs_from_the_exact_equation_only_at_second_order(n):
    """kernel - exact is even-dominated at S0: halving the deck scale divides it by ~4 (a missing
    first-order term would divide it by 2).
    """
    for params, (y, qdd, deck) in states(n, seed=500):
        sc = theta_scale(params, y[7 + n])

        def diff(s):
            ys, qs = at_scale(y, qdd, deck, s)
            return (kernel_theta_residual(params, ys, qs) - L.theta_residuals(params, ys, qs)[0]
                    ) / sc
        full, half = diff(S0), diff(S0 / 2)
        assert abs(full) < 1e4 * S0 ** 2
        assert 3.5 < full / half < 4.5, (full, half)


@pytest.mark.parametrize('n', [0, 1, 2, 3])
def test_torque_mode_accelerations_solve_every_first_order_equation(n):
    """kernels.rhs.accel in torque mode: q'' makes the first-order Lagrange residual of X..phi_n
    vanish and that of theta equal Q_theta (motor torque less friction), to round-off.
    """
    motor = TorqueMotor(K_t=0.02, I_max=2.0, T_c=2e-4)
    S = motor.pack(1.5)
    for params, (y, qdd, deck) in states(n, seed=600):
        y, _ = at_scale(y, qdd, deck, 0.05)
        N = 7 + n
        w = y[N]
        Q = kernels.PY.spindle_torque(w, S)
        for kern in (kernels.PY, kernels.JIT):
            kern.accel(0.0, y, n, kernels.pack_params(params), S, qdd,
                       equations.solver_buffers(n))
            rows = L.first_order_residual(params, y, qdd) / scales(params, w)
            _, first = L.theta_residuals(params, y, qdd)
            assert np.max(np.abs(rows)) < ROUND_OFF, rows
            assert abs((first - Q) / theta_scale(params, w)) < ROUND_OFF, (first, Q)

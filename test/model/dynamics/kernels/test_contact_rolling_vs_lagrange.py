"""The ball-size, contact and rolling terms of the kernels against the extended energies.

test/lagrange_sympy.py adds to T, V, F (docs/ball_size_contact_rolling.md): the rolling balls' spin
energy 1/2 J_b |omega_P + (theta' - R/r phi_i') e_z|^2, the Hertz potential 2/5 K delta^2.5 and
the Hunt-Crossley dissipation 1/2 chi K delta^1.5 delta'^2 of every overlapping pair. The
kernels (abb_ros.model.dynamics.kernels: add_ball_rotation, contact_forces, and the 7/5 ball mass
in accel) must equal the first-order expansion of Lagrange's equations of these energies to
round-off, at random states with theta'' != 0, exactly as the paper's terms do
(test_equations_vs_lagrange.py).
"""

import lagrange_sympy as L
import numpy as np
import pytest
from test_equations_vs_lagrange import ROUND_OFF, at_scale, random_state, scales

from abb_ros.model.dynamics import equations
from abb_ros.model.parameters.params import DriveParams

R_BALL = 2.87e-3
"""A steel ball (7850 kg/m^3) of the P1/P3 mass m = 0.03 M = 0.78 g: r = 2.87 mm."""
OVERLAP = 1e-6
"""Pairs of the contact states overlap by 1 um (contact force ~ K delta^1.5 ~ 5 N)."""


def beyond_states(n, contact, seed):
    """Return random states of the extended model (balls just touching with contact).

    Random states (test_equations_vs_lagrange.random_state) of the extended model; with contact,
    ball j sits just inside the contact distance of ball j - 1 (every pair of n = 2 overlaps by
    OVERLAP, the pair ordering 0 < phi_2 - phi_1 < pi of the sympy side).
    """
    extra = dict(r_ball=R_BALL, ball_rotation=1)
    if contact:
        extra.update(contact_E=2.0e11, contact_nu=0.3, contact_damping=0.05)
    params = DriveParams(n=n, m=0.78e-3, **extra)
    rng = np.random.default_rng(seed)
    for _ in range(4):
        y, qdd, deck = random_state(params, rng, rng.uniform(-2000.0, 2000.0))
        if contact:
            sep = 2.0 * np.arcsin((R_BALL - OVERLAP / 2) / params.R)
            y[8] = y[7] + sep
        yield params, y, qdd, deck


@pytest.mark.parametrize('n, contact', [(1, False), (2, True)])
def test_beyond_paper_kernels_are_the_first_order_expansion_of_the_extended_energies(n, contact):
    """lagrange_residual (the kernels' assemble with ball rotation and contact, 7/5 ball mass)
    equals the first-order Lagrange equations of the extended T, V, F to round-off.
    """
    for params, y, qdd, deck in beyond_states(n, contact, seed=12 + n):
        y, qdd = at_scale(y, qdd, deck, 0.05)
        sc = scales(params, y[7 + n])
        err = equations.lagrange_residual(params, y, qdd) - L.first_order_residual(params, y, qdd)
        assert np.max(np.abs(err / sc)) < ROUND_OFF, err / sc


def test_contact_state_really_overlaps_and_pushes_the_balls_apart():
    """The contact states of the test above exercise the contact force: Q_2 = -Q_1 > 0 and of the
    size K delta^1.5 R (not a vacuous comparison).
    """
    from abb_ros.model.dynamics import kernels
    params, y, _, _ = next(beyond_states(2, True, seed=1))
    P = kernels.pack_params(params)
    Qc = np.empty(2)
    energy, _ = kernels.JIT.contact_forces(y, 2, P, Qc)
    K = kernels.JIT.contact_stiffness(P)
    assert Qc[1] == pytest.approx(-Qc[0])
    # K delta^1.5 R cos(dphi/2) (1 + chi delta'): cos(11 deg) = 0.98, chi delta' within 10 %
    assert 0.8 < Qc[1] / (K * OVERLAP ** 1.5 * params.R) < 1.1
    assert energy == pytest.approx(0.4 * K * OVERLAP ** 2.5, rel=1e-6)

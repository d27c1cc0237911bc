"""The rotor's leaning principal axis, couple imbalance (docs/equations.md F6), vs the energies.

The rotor's inertia in its own axes is J_G = R^T diag(J_x, J_y, J_z) R, exact in the lean tau
(test/lagrange_sympy.py: rotor_inertia); the kernels carry Lagrange's equations of that energy to
first order in the deck coordinates. The claims: the rows are that expansion, the dropped terms
are second order, and at rest the leaning axis acts as the point couple of resultant
-(J_z - J_x) sin tau cos tau exp(i psi_tau) that two-plane balancing cancels.
"""

import math

import lagrange_sympy as L
import numpy as np
import pytest
import sympy as sp
from test_equations_vs_lagrange import (
    EVEN_RATIO,
    FLOOR,
    ODD_RATIO,
    ROUND_OFF,
    S0,
    SECOND_ORDER_BOUND,
    _parts,
    at_scale,
    random_state,
    scales,
)
from test_heights_vs_lagrange import HEIGHTS, settled

from abb_ros.model.dynamics import equations
from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.dynamics.spindle import TorqueMotor
from abb_ros.model.parameters.params import DriveParams, ParamError, apply_settings
from abb_ros.model.stability import coupled, two_plane

LEAN = dict(tau=0.05, psi_tau=0.7)
"""A 3 degree lean toward 40 degrees from G: a large couple imbalance for a disc rotor."""
P3 = DriveParams(c=0.66, m=0.03 * 0.026)
W3 = 2.7 * P3.omega0


def leaning_states(n, seed, **extra):
    """Yield 6 random (params, y, qdd, deck) of n balls with LEAN (and ``extra``), theta'' != 0."""
    params = DriveParams(n=n, **LEAN, **extra)
    rng = np.random.default_rng(seed + n)
    for _ in range(6):
        yield (params, *random_state(params, rng, rng.uniform(-2000.0, 2000.0)))


def test_the_leaning_inertia_is_the_axisymmetric_tensor_about_the_leaning_axis():
    """R^T diag R with J_x = J_y is J_x I + (J_z - J_x) n n^T, n the leaning axis (exact)."""
    _, _, _, par = L.symbols(0)
    J = L.rotor_inertia(par, True).subs(par['J_y'], par['J_x'])
    tau, psi = par['tau'], par['psi_tau']
    n = sp.Matrix([sp.sin(tau) * sp.cos(psi), sp.sin(tau) * sp.sin(psi), sp.cos(tau)])
    want = par['J_x'] * sp.eye(3) + (par['J_z'] - par['J_x']) * n * n.T
    assert sp.simplify(J - want) == sp.zeros(3, 3)


@pytest.mark.parametrize('n,extra', [(0, {}), (2, {}), (2, HEIGHTS)])
def test_leaning_axis_rows_are_the_first_order_expansion_of_the_energies(n, extra):
    """Round-off agreement of two first-order forms, as for the heights (ROUND_OFF)."""
    for params, y, qdd, deck in leaning_states(n, 800, **extra):
        y, qdd = at_scale(y, qdd, deck, 0.05)
        err = equations.lagrange_residual(params, y, qdd) - L.first_order_residual(params, y, qdd)
        assert np.max(np.abs(err / scales(params, y[7 + n]))) < ROUND_OFF


def test_leaning_axis_rows_differ_from_the_exact_equations_only_at_second_order():
    """O(s^2) against the untruncated equations, split as in the plane's test into the even
    part (ratio 4 when s halves) and the odd part (ratio 8: no first-order term is missing; a
    lean makes third-order terms large enough to hide that in a plain two-point ratio)."""
    for params, y, qdd, deck in leaning_states(2, 900):
        sc = scales(params, y[9])
        full, even, odd = _parts(params, y, qdd, deck, S0, sc)
        _, even_half, odd_half = _parts(params, y, qdd, deck, S0 / 2, sc)
        assert np.all(np.abs(full) <= SECOND_ORDER_BOUND * S0 ** 2)
        for part, half, (low, high) in ((even, even_half, EVEN_RATIO), (odd, odd_half, ODD_RATIO)):
            above = np.abs(part) > FLOOR
            ratio = part[above] / half[above]
            assert np.all((ratio > low) & (ratio < high)), (np.flatnonzero(above), ratio)


def test_leaning_axis_accelerations_solve_the_rows():
    for params, y, qdd, deck in leaning_states(2, 1000):
        y, _ = at_scale(y, qdd, deck, 0.05)
        res = equations.lagrange_residual(params, y, equations.accelerations(params, y))
        assert np.max(np.abs(res / scales(params, y[9]))) < 1e-10


def test_at_rest_a_leaning_axis_is_the_point_couple_two_plane_balancing_cancels():
    """The forcing of the coupled linearisation at rest: a lean toward psi_tau = pi with
    (J_z - J_x) sin tau cos tau = M eps h gives the moment rows of G lifted by h, to round-off
    (so U_c = M eps z_G - (J_z - J_x) sin tau cos tau exp(i psi_tau) has the right sign)."""
    h = 0.001
    tau = 0.5 * math.asin(2 * P3.M * P3.eps * h / (P3.J_z - P3.J_x))
    lean = apply_settings(P3, {'tau': tau, 'psi_tau': math.pi})[0]
    lifted = apply_settings(P3, {'z_G': h})[0]
    F_lean = coupled.coupled_system(lean, W3).F
    F_lift = coupled.coupled_system(lifted, W3).F
    scale = P3.M * P3.eps * W3 ** 2 * h
    assert np.abs(F_lean[:, 3:5] - F_lift[:, 3:5]).max() <= 1e-12 * scale
    assert two_plane.imbalance_couple(lean) == pytest.approx(two_plane.imbalance_couple(lifted),
                                                             abs=1e-12 * P3.M * P3.eps * h)


def test_a_leaning_axis_in_torque_mode_or_with_ball_terms_is_refused_naming_tau():
    with pytest.raises(ParamError, match="'tau'.*contact_E"):
        DriveParams(tau=0.01, r_ball=1e-3, contact_E=2e11)
    with pytest.raises(ParamError, match="'tau'.*torque"):
        Simulation(DriveParams(tau=0.01), 300.0, spindle=TorqueMotor())


@pytest.mark.slow
def test_a_leaning_axis_tilts_the_deck_as_the_linearisation_predicts(abb_sim, tmp_path):
    """P3 with the axis leaning 0.5 mrad: the balls cancel the force, the couple tilts the
    deck; the run's fitted tilt equals the coupled linearisation's periodic response to 0.1 %
    (the dropped terms are of relative order the tilt)."""
    run = settled(abb_sim, tmp_path, 'tau=0.0005', 'psi_tau=1.0')
    lean = apply_settings(P3, {'tau': 0.0005, 'psi_tau': 1.0})[0]
    assert run['final_rbar'] < 1e-3
    assert run['tilt_rad'] == pytest.approx(coupled.residual_tilt(lean, W3), rel=1e-3)

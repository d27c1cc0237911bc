"""The coupled linearisation of mass centres off the washers' plane (docs/equations.md, F4-F5).

The coupled system is taken from the nonlinear rows (abb_ros.model.stability.coupled); the
independent checks are the paper's own linearisation, Eqs. (27)-(33), wherever it applies (zero
heights: every coefficient and every multiplier), the nonlinear simulation (the residual tilt
one race leaves is the periodic response of the linearisation), and the balls' statics (a race
in G's plane cancels force and couple alike).
"""

import dataclasses
import json
import math

import numpy as np
import pytest
from test_heights_vs_lagrange import settled

from abb_ros.model.parameters.params import DriveParams, apply_settings
from abb_ros.model.stability import coupled, floquet, linear, speed_bands

P3 = DriveParams(c=0.66, m=0.03 * 0.026)
W3 = 2.7 * P3.omega0
IN = [0, 1, 5, 6, 7]      # X, Y, gamma, phi_1, phi_2 in the coupled order
OUT = [2, 3, 4]           # Z, alpha, beta


def lifted(**heights) -> DriveParams:
    return apply_settings(P3, heights)[0]


def test_in_the_plane_the_coupled_rows_are_eqs_27_to_33():
    """Zero heights: the rows' linearisation equals the paper's, group by group, and couples
    nothing across the groups. Tolerances: M and K to 1e-12 of their largest entry (the same
    polynomial evaluated in another order; the central differences are exact for the rows'
    quadratic rate terms), C to 1e-9 (central differences of the trigonometric terms, step
    1e-6: truncation ~1e-12, round-off ~1e-10 of the row scale)."""
    sys = coupled.coupled_system(P3, W3).system
    phi = coupled.balanced_phi_star(P3, None)
    groups = ((IN, linear.in_plane_harmonics(P3, W3, phi)),
              (OUT, linear.out_of_plane_harmonics(P3, W3, phi)))
    for H, tol, i in ((sys.M, 1e-12, 0), (sys.C, 1e-9, 1), (sys.K, 1e-12, 2)):
        scale = np.abs(H).max()
        for idx, ref in groups:
            block = H[:, idx][:, :, idx]
            padded = np.zeros_like(block)
            padded[:ref[i].shape[0]] = ref[i]
            assert np.abs(block - padded).max() <= tol * scale
        assert np.abs(H[:, IN][:, :, OUT]).max() == 0.0
        assert np.abs(H[:, OUT][:, :, IN]).max() == 0.0


def test_lam_max_is_the_larger_group_value_over_one_spindle_period():
    """Zero heights, 0-1500 rad/s: lam_max over T = max(in-plane, out-of-plane^2), the
    out-of-plane group's period being T / 2 (to 1e-6: the fixed-step RK4 monodromies of
    different step counts; measured 8e-8)."""
    omegas = np.linspace(5.0, 1500.0, 120)
    lam = coupled.lam_max_sweep(P3, omegas)
    lam_in = floquet.sweep_speed(P3, omegas, 'in')
    lam_out = floquet.sweep_speed(P3, omegas, 'out')
    assert lam == pytest.approx(np.maximum(lam_in, lam_out ** 2), rel=1e-6)


@pytest.mark.parametrize('n', [3, 4])
def test_family_directions_stay_neutral_with_a_height(n):
    """n >= 3: the balanced family's n - 2 directions move neither force nor couple of a race
    in one plane, so they stay neutral (removed, self-checked) and the rest matches the
    point computation."""
    p = apply_settings(P3, {'n': n, 'z_G': 0.002})[0]
    point = coupled.coupled_stability(p, W3)
    assert point.neutral == n - 2 and point.invariance < coupled.INVARIANCE_TOL
    assert coupled.lam_max_sweep(p, [W3])[0] == pytest.approx(point.lam_max, rel=1e-9)


def test_speed_polynomial_gives_the_direct_linearisation_at_any_speed():
    """theta' enters the rows as a rate, quadratically at most: three speeds give all (to 1e-8
    of each matrix: C's central differences carry ~1e-10 of noise, which the quadratic
    through 0, 1, 2 omega0 amplifies ~20 times at 4 omega0; measured 1.9e-9)."""
    p = lifted(z_G=0.003, z_P=-0.002, z_B=0.001)
    poly = coupled.speed_polynomial(p)
    for omega in (137.0, 1234.5):
        direct = coupled.coupled_system(p, omega).system
        for got, want in zip(poly.at([omega])[:3], (direct.M, direct.C, direct.K)):
            assert np.abs(got[0] - want).max() <= 1e-8 * np.abs(want).max()


def test_natural_frequencies_in_the_plane_match_section_4_and_heights_move_them():
    """With the rotor's mass on its axis (the coupled value's convention; Eqs. 27-33 keep
    eps's mass terms, 2.5e-5 apart at Table 1) the plane's values to 1e-8."""
    plane = linear.natural_frequencies(dataclasses.replace(P3, eps=0.0))
    assert coupled.natural_frequencies(P3) == pytest.approx(plane, rel=1e-8)
    high = coupled.natural_frequencies(lifted(z_P=0.01))
    assert high['X'] < 0.98 * plane['X']          # the deck's mass rocks on the washers


def test_a_race_in_the_rotor_plane_leaves_no_tilt_to_predict():
    tilt = coupled.residual_tilt(lifted(z_G=0.005, z_B=0.005), W3)
    assert tilt < 1e-15


def test_predicted_tilt_grows_with_the_lever_of_the_couple():
    """Twice the lever, twice the couple: twice the tilt, but for the inertia the lever adds
    (M z_G^2 in the tilt rows; measured ratio 1.9957)."""
    small, big = (coupled.residual_tilt(lifted(z_G=z), W3) for z in (0.0005, 0.001))
    assert big / small == pytest.approx(2.0, rel=5e-3)


def test_predicted_tilt_is_linear_in_the_couple_of_a_leaning_axis():
    """The lean's couple k = (J_z - J_x) sin tau cos tau drives the tilt; its inertia term
    (J_z - J_x) sin^2 tau is of second order, so for tiny leans the tilt doubles with the
    couple to that order (tau = 1e-4: ~1e-8 relative; 1e-6 allowed for the integration)."""
    tilt = [coupled.residual_tilt(lifted(tau=t), W3) for t in (1e-4, 2e-4)]
    k = [math.sin(t) * math.cos(t) for t in (1e-4, 2e-4)]
    assert tilt[1] / tilt[0] == pytest.approx(k[1] / k[0], rel=1e-6)


@pytest.mark.slow
def test_residual_tilt_from_simulation_equals_the_periodic_linear_response(abb_sim, tmp_path):
    """P3 with G 0.5 mm above the race, 6 s: the nonlinear run's fitted tilt (abb-sim run
    --json) equals the periodic solution of the coupled linearisation to 0.1 %. The
    linearisation drops terms of relative order the tilt itself (7e-4 rad) and the balls'
    shift; measured 2.2e-4 at 0.5 mm, 2.9e-4 at 1 mm."""
    run = settled(abb_sim, tmp_path, 'z_G=0.0005')
    assert run['tilt_rad'] == pytest.approx(coupled.residual_tilt(lifted(z_G=0.0005), W3),
                                            rel=1e-3)


def test_analysis_of_a_lifted_drive_reports_tilt_and_the_second_race():
    """The verdict a person reads: lam_max of the coupled system, the predicted tilt and
    which second race (mirrored about G: 2 mm, half the imbalance each) removes it."""
    p = lifted(z_G=0.001)
    table = speed_bands.speed_table(p, 1500.0)
    a = speed_bands.assess(table, W3, speed_bands.refine(table, W3))
    assert a.level == speed_bands.OK and 'residual tilt' in a.message
    assert a.values['second_race_z_m'] == pytest.approx(0.002)
    assert a.values['second_race_B_kg_m'] == pytest.approx(p.M * p.eps / 2)
    assert a.values['lambda_max'] == pytest.approx(coupled.coupled_stability(p, W3).lam_max)
    assert a.values['residual_tilt_rad'] == pytest.approx(coupled.residual_tilt(p, W3))


def test_stability_command_gives_lam_max_beside_the_group_values(abb_sim):
    """The command's lam_max (from the groups of Eqs. 27-33) is the coupled linearisation's
    over the period, computed independently (1e-6, as above)."""
    code, out, err = abb_sim('stability', '--set', 'wbar=2.7', '--json')
    assert code == 0, err
    res = json.loads(out)
    assert res['lam_max'] == max(res['lam_max_in_plane'], res['lam_max_out_of_plane'] ** 2)
    table1 = DriveParams()
    assert res['lam_max'] == pytest.approx(
        coupled.lam_max_sweep(table1, [2.7 * table1.omega0])[0], rel=1e-6)
    code, out, err = abb_sim('stability', '--set', 'wbar=2.7', '--set', 'z_G=0.001', '--json')
    assert code == 0, err
    res = json.loads(out)
    assert 'lam_max_in_plane' not in res and res['residual_tilt_rad'] > 0
    assert res['second_race']['z_m'] == pytest.approx(0.002)
    assert math.isfinite(res['lam_max'])


def test_a_map_over_a_height_and_speed_is_of_the_coupled_linearisation():
    """Every point of a map with a height axis has the coupled lam_max; its z_G = 0 row is the
    plane's max(in-plane, out-of-plane^2)."""
    wbar = np.linspace(1.5, 3.0, 4)
    smap = floquet.stability_map(P3, 'wbar', wbar, 'z_G', [0.0, 0.002])
    assert smap.plane == 'coupled'
    omegas = wbar * P3.omega0
    plane = np.maximum(floquet.sweep_speed(P3, omegas, 'in'),
                       floquet.sweep_speed(P3, omegas, 'out') ** 2)
    assert smap.lam[0] == pytest.approx(plane, rel=1e-6)
    assert smap.lam[1] == pytest.approx(coupled.lam_max_sweep(lifted(z_G=0.002), omegas))


def test_map_command_draws_a_height_against_speed(abb_sim, tmp_path):
    code, out, err = abb_sim('map', '--x', 'wbar', '--y', 'z_G', '--res', '4x3', '--no-progress',
                             '--json', '--out', str(tmp_path / 'zg.png'))
    assert code == 0, err
    res = json.loads(out)
    assert res['plane'] == 'coupled' and (tmp_path / 'zg.png').stat().st_size > 0

"""Balanced equilibrium (Eqs. 26, 34), linearised Eqs. (27)-(33) and natural frequencies.

Sources: Kim, Lee & Chung (2005), Section 3 (equations), Section 4 (natural frequencies:
omega0 ~ 298, omega_alpha = 535, omega_beta = 750, omega_gamma = 577 rad/s).
"""

import math

import numpy as np
import pytest

from abb_ros.model.dynamics import equations
from abb_ros.model.dynamics.state import DECK, StateLayout
from abb_ros.model.parameters.params import DriveParams, ParamError, apply_settings
from abb_ros.model.stability.equilibrium import (
    balanced_equilibrium,
    epsbar_lim,
    eq26_residual,
    mbar_lim,
    phi_star_two_balls,
)
from abb_ros.model.stability.linear import in_plane, natural_frequencies, out_of_plane

TABLE1 = DriveParams()
P3, OMEGA_P3 = apply_settings(TABLE1, {'zeta': 0.025, 'mbar': 0.03, 'wbar': 2.7})


def test_printed_eq34_puts_balls_on_the_wrong_side_and_corrected_form_balances():
    ratio = P3.M * P3.eps / (P3.m * P3.R)
    printed = -math.atan(math.sqrt((2 / ratio) ** 2 - 1))
    # The printed Eq. (34) leaves an Eq. (26) residual of order 1 (balls on G's side).
    assert abs(math.degrees(printed)) < 90
    assert eq26_residual(P3, [printed, -printed]) > 0.5
    phi1, phi2 = phi_star_two_balls(ratio)
    # 1e-12: the corrected form is exact up to round-off.
    assert eq26_residual(P3, [phi1, phi2]) < 1e-12
    assert math.degrees(phi1) == pytest.approx(-106.13, abs=0.01)  # paper's sign: phi_1* < 0
    assert phi2 == -phi1


@pytest.mark.parametrize('n', [2, 3, 4, 5, 10])
def test_symmetric_fan_solves_eq26_for_any_number_of_balls(n):
    params = TABLE1.replace(n=n)
    eq = balanced_equilibrium(params)
    assert eq.exists and eq.phi_star.shape == (n,)
    assert eq26_residual(params, eq.phi_star) < 1e-12  # bisection to round-off
    assert np.all(np.abs(eq.phi_star) <= math.pi)


def test_explicit_phi_star_is_accepted_only_if_it_balances():
    phi = balanced_equilibrium(P3).phi_star
    assert np.array_equal(balanced_equilibrium(P3, phi[::-1]).phi_star, phi[::-1])
    with pytest.raises(ParamError, match='phi_star'):
        balanced_equilibrium(P3, [0.1, 0.2])
    with pytest.raises(ParamError, match='phi_star'):
        balanced_equilibrium(P3, [0.1, 0.2, 0.3])


def test_no_balanced_equilibrium_beyond_the_balls_capacity():
    # P4: epsbar = 0.04 with the Table 1 ball mass: 2 m R < M eps.
    p4, _ = apply_settings(TABLE1, {'epsbar': 0.04})
    eq = balanced_equilibrium(p4)
    assert not eq.exists and 'capacity' in eq.reason
    assert eq.phi_star.size == 0 and not np.isnan(eq.phi_star).any()
    with pytest.raises(ParamError):
        in_plane(p4, 800.0)


def test_balancing_limits_are_where_two_balls_just_cancel_the_imbalance():
    # Fig. 6: epsbar_lim = 2 mbar; Fig. 7: mbar_lim = epsbar / 2 (n = 2: 2 m R = M eps).
    assert epsbar_lim(TABLE1) == pytest.approx(2 * TABLE1.mbar, rel=1e-12)
    assert mbar_lim(TABLE1) == pytest.approx(TABLE1.epsbar / 2, rel=1e-12)
    at_lim, _ = apply_settings(TABLE1, {'mbar': mbar_lim(TABLE1) * (1 + 1e-9)})
    below, _ = apply_settings(TABLE1, {'mbar': mbar_lim(TABLE1) * (1 - 1e-6)})
    assert balanced_equilibrium(at_lim).exists
    assert not balanced_equilibrium(below).exists


def test_natural_frequencies_agree_with_the_paper_within_four_percent():
    f = natural_frequencies(TABLE1)
    paper = {'X': 298, 'Y': 298, 'Z': 298, 'alpha': 535, 'beta': 750, 'gamma': 577}
    for name, value in paper.items():
        # 4 %: the paper's values are rounded and its omega0 (298) is 0.8 % below
        # sqrt(4k/(M+M_P)) from Table 1; beta differs most (774 vs 750, 3.2 %).
        assert f[name] == pytest.approx(value, rel=0.04), name
    assert f['Y'] == pytest.approx(TABLE1.omega0, rel=1e-12)
    assert f['beta'] > f['gamma'] > f['alpha'] > f['Y']  # rotational above translational


def _paper_in_plane(p, w, phi, t):
    """Eqs. (27), (28), (32), (33) written out term by term (independent of linear.py)."""
    n = len(phi)
    nq = 3 + n
    M, C, K = np.zeros((nq, nq)), np.zeros((nq, nq)), np.zeros((nq, nq))
    Mt = p.M + p.M_P + n * p.m
    G = p.a ** 2 + p.b ** 2 + 4 * p.d ** 2
    Jg = p.J_z + p.J_Pz + p.M_P * p.d ** 2 + p.M * p.eps ** 2 + n * p.m * p.R ** 2
    mR, mR2 = p.m * p.R, p.m * p.R ** 2
    M[0, 0] = M[1, 1] = Mt
    C[0, 0] = C[1, 1] = 4 * p.c
    K[0, 0] = K[1, 1] = 4 * p.k
    M[0, 2], C[0, 2], K[0, 2] = p.d * p.M_P, 4 * p.d * p.c, 4 * p.d * p.k
    M[2, 0], C[2, 0], K[2, 0] = p.d * p.M_P, 4 * p.d * p.c, 4 * p.d * p.k
    M[2, 2], C[2, 2], K[2, 2] = Jg, G * p.c, G * p.k
    for i in range(n):
        s, c = math.sin(phi[i] + w * t), math.cos(phi[i] + w * t)
        j = 3 + i
        M[0, j], C[0, j], K[0, j] = -mR * s, -2 * mR * w * c, mR * w ** 2 * s
        M[1, j], C[1, j], K[1, j] = mR * c, -2 * mR * w * s, -mR * w ** 2 * c
        M[2, j] = mR2
        M[j, 0], M[j, 1], M[j, 2], M[j, j] = -mR * s, mR * c, mR2, mR2
        C[j, j] = p.D
    return M, C, K


def _paper_out_of_plane(p, w, phi, t):
    """Eqs. (29)-(31) written out term by term (independent of linear.py)."""
    ang = np.concatenate([[w * t], np.asarray(phi) + w * t])
    wt = np.concatenate([[p.M * p.eps ** 2], np.full(len(phi), p.m * p.R ** 2)])
    S2 = (wt * np.sin(ang) ** 2).sum()
    C2 = (wt * np.cos(ang) ** 2).sum()
    SC = (wt * np.sin(ang) * np.cos(ang)).sum()
    n = len(phi)
    d, c, k = p.d, p.c, p.k
    M = np.array([[p.M + p.M_P + n * p.m, -d * p.M_P, 0],
                  [-d * p.M_P, p.J_x + p.J_Px + p.M_P * d ** 2 + S2, -SC],
                  [0, -SC, p.J_y + p.J_Py + C2]])
    C = np.array([[4 * c, -4 * d * c, 0],
                  [-4 * d * c, (p.b ** 2 + 4 * d ** 2) * c + 2 * w * SC, p.J_z * w + 2 * w * S2],
                  [0, -(p.J_z * w + 2 * w * C2), p.a ** 2 * c - 2 * w * SC]])
    K = np.array([[4 * k, -4 * d * k, 0],
                  [-4 * d * k, (p.b ** 2 + 4 * d ** 2) * k, 0],
                  [0, 0, p.a ** 2 * k]])
    return M, C, K


@pytest.mark.parametrize('n', [2, 5])
def test_harmonic_matrices_equal_the_printed_equations_at_any_time(n):
    params = P3.replace(n=n)
    rng = np.random.default_rng(3)
    phi = balanced_equilibrium(params).phi_star
    for build, ref in ((in_plane, _paper_in_plane), (out_of_plane, _paper_out_of_plane)):
        sys_ = build(params, OMEGA_P3)
        for t in rng.uniform(0, 0.02, 5):
            for got, want in zip(sys_.at(t), ref(params, OMEGA_P3, phi, t)):
                # 1e-12 relative: the same sums in another order, round-off only.
                np.testing.assert_allclose(got, want, rtol=1e-12,
                                           atol=1e-12 * np.abs(want).max())


def test_mass_matrices_are_symmetric_with_eq33_accelerations():
    # With X'', Y'' in Eq. (33) the ball rows mirror the ball columns of Eqs. (27)-(28).
    for build in (in_plane, out_of_plane):
        M, _, _ = build(P3, OMEGA_P3).at(1.234e-3)
        np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-15)


IN_ROWS = [0, 1, 5]    # X, Y, gamma in the nonlinear residual order [X, Y, Z, alpha, beta, gamma]
OUT_ROWS = [2, 3, 4]   # Z, alpha, beta


def _fd_linearisation(params, omega, phi, t, h=1e-7):
    """d residual / d(q, q', q'') of the nonlinear model at the balanced equilibrium (central
    differences), rows and columns in the order [X, Y, Z, alpha, beta, gamma, phi_i]."""
    n = params.n
    s = StateLayout(n)
    y0 = s.pack(theta=omega * t, phi=phi, omega=omega)
    qdd0 = np.zeros(s.N)
    out = []
    for part in ('q', 'qd', 'qdd'):
        J = np.zeros((6 + n, 6 + n))
        for j in range(6 + n):
            cols = []
            for sgn in (1, -1):
                y, qdd = y0.copy(), qdd0.copy()
                if part == 'q':
                    y[DECK + j] += sgn * h
                elif part == 'qd':
                    y[s.N + DECK + j] += sgn * h
                else:
                    qdd[DECK + j] += sgn * h
                cols.append(equations.lagrange_residual(params, y, qdd))
            J[:, j] = (cols[0] - cols[1]) / (2 * h)
        out.append(J)
    return out[2], out[1], out[0]   # M, C, K


def test_linearised_matrices_equal_a_finite_difference_linearisation_of_the_nonlinear_model():
    params = P3
    phi = balanced_equilibrium(params).phi_star
    t = 0.37e-3
    Mf, Cf, Kf = _fd_linearisation(params, OMEGA_P3, phi, t)
    n = params.n
    in_idx = IN_ROWS + list(range(6, 6 + n))
    for sys_, idx in ((in_plane(params, OMEGA_P3), in_idx),
                      (out_of_plane(params, OMEGA_P3), OUT_ROWS)):
        for got, fd in zip(sys_.at(t), (Mf, Cf, Kf)):
            want = fd[np.ix_(idx, idx)]
            # Central differences with h = 1e-7 on a residual of size ~1e1 (N, N m): round-off
            # ~1e-16 * 10 / 1e-7 = 1e-8 absolute; truncation h^2 * (third derivative) is smaller.
            np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-6 * np.abs(want).max())
    # Section 4: in-plane and out-of-plane motions decouple at the balanced equilibrium.
    out_idx = OUT_ROWS
    for fd in (Mf, Cf, Kf):
        scale = np.abs(fd).max()
        assert np.abs(fd[np.ix_(in_idx, out_idx)]).max() < 1e-6 * scale
        assert np.abs(fd[np.ix_(out_idx, in_idx)]).max() < 1e-6 * scale

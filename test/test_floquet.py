"""Monodromy matrices and Floquet multipliers (floquet.py) against exact and reference results."""

import math

import numpy as np
import pytest

from abb_ros.model.parameters.params import DriveParams, apply_settings
from abb_ros.model.stability import floquet as F
from abb_ros.model.stability.linear import PeriodicSystem, in_plane, out_of_plane

TABLE1 = DriveParams()


def _point(**settings):
    return apply_settings(TABLE1, settings)


@pytest.mark.skipif(not F.JIT.compiled, reason='kernels not compiled (numba missing or '
                    'ABB_ROS_NO_JIT set): JIT is the twin itself')
def test_compiled_kernel_agrees_with_its_python_twin():
    p, w = _point(zeta=0.025, mbar=0.03, wbar=2.18)
    for build in (in_plane, out_of_plane):
        sys_ = build(p, w)
        jit = F.monodromy(sys_, nsteps=40, kern=F.JIT)
        py = F.monodromy(sys_, nsteps=40, kern=F.PY)
        # Same statements; fastmath may reorder sums: round-off level, 1e-10 relative.
        np.testing.assert_allclose(jit, py, rtol=1e-10, atol=1e-10 * np.abs(py).max())


def test_constant_coefficients_give_multipliers_exp_lambda_T():
    rng = np.random.default_rng(7)
    nq = 4
    A = rng.normal(size=(nq, nq))
    M = A @ A.T + nq * np.eye(nq)
    C = rng.normal(size=(nq, nq)) * 0.5
    K = rng.normal(size=(nq, nq)) * 3 + 10 * np.eye(nq)
    omega = 2.0
    H = lambda X: np.stack([X, 0 * X, 0 * X])  # noqa: E731  harmonic 0 only
    sys_ = PeriodicSystem(H(M), H(C), H(K), omega, 2 * math.pi / omega, tuple('abcd'))
    exact = np.sort(np.abs(np.exp(np.linalg.eigvals(sys_.state_matrix(0.0)) * sys_.period)))
    got = np.sort(np.abs(F.multipliers(F.monodromy(sys_))))
    # RK4 at the module's step rule: the accuracy target of the maps, 1e-6.
    np.testing.assert_allclose(got, exact, rtol=1e-6)


@pytest.mark.parametrize('plane', ['in', 'out'])
def test_monodromy_satisfies_liouville_determinant(plane):
    p, w = _point(zeta=0.025, mbar=0.03, wbar=2.7)
    sys_ = (in_plane if plane == 'in' else out_of_plane)(p, w)
    # integral of trace A = -tr(M^-1 C) over the period: trapezoid on a periodic smooth
    # integrand converges spectrally; 2000 nodes are exact to round-off.
    t = np.linspace(0, sys_.period, 2001)[:-1]
    exact = math.exp(np.mean([np.trace(sys_.state_matrix(ti)) for ti in t]) * sys_.period)
    n0 = int(F.steps_for(F.fastest_rate(sys_), sys_.omega * sys_.period))
    err = [abs(np.linalg.det(F.monodromy(sys_, nsteps=k * n0)) / exact - 1) for k in (1, 2)]
    # At the step rule: det is a product of 2 nq multipliers each good to ~1e-7: 1e-6.
    assert err[0] < 1e-6
    # RK4: halving the step divides the error by ~16 (fourth order); accept 10..20.
    assert 10 < err[0] / err[1] < 20


def _boundary_points():
    """Operating points on the stability boundary |lambda|max = 1 (metal washers, P1-P3 line)."""
    from scipy.optimize import brentq
    p, _ = _point(zeta=0.025, mbar=0.03)
    wbar = np.linspace(1.0, 3.0, 101)
    lam = F.sweep_speed(p, wbar * p.omega0)
    cross = np.flatnonzero(np.diff(np.sign(lam - 1.0)))[:3]
    f = lambda w: F.sweep_speed(p, [w])[0] - 1.0  # noqa: E731
    return [(p, brentq(f, wbar[i] * p.omega0, wbar[i + 1] * p.omega0, xtol=1e-9))
            for i in cross]


@pytest.mark.slow
def test_largest_multiplier_matches_a_tight_dop853_reference_within_1e_6():
    rng = np.random.default_rng(11)
    points = _boundary_points()
    for _ in range(4):
        points.append(_point(zeta=rng.uniform(0.005, 0.15), mbar=rng.uniform(0.01, 0.12),
                             Dbar=rng.uniform(0.02, 1.0), wbar=rng.uniform(0.3, 3.5)))
    near_one = 0
    for p, w in points:
        for plane, build in (('in', in_plane), ('out', out_of_plane)):
            ref = F.max_multiplier(F.monodromy_reference(build(p, w)))
            got = F.sweep_speed(p, [w], plane)[0]
            near_one += abs(ref - 1.0) < 1e-4
            # The accuracy target; DOP853 at rtol = atol = 1e-12 is ~1e-11 accurate.
            assert abs(got - ref) < 1e-6, (plane, p.dimensionless(), w)
    assert near_one >= 3


def test_speed_sweep_equals_the_point_by_point_result():
    p, _ = _point(zeta=0.025, mbar=0.03)
    w = np.array([0.8, 2.18, 2.7]) * p.omega0
    lam = F.sweep_speed(p, w)
    for wi, li in zip(w, lam):
        assert F.point_stability(p, wi).lam_in == li


def test_out_of_plane_coefficients_have_half_the_in_plane_period():
    p, w = _point(mbar=0.03, wbar=2.7)
    o = out_of_plane(p, w)
    i = in_plane(p, w)
    assert o.period == pytest.approx(i.period / 2, rel=1e-15)
    t = 1.1e-3
    for a, b in zip(o.at(t), o.at(t + o.period)):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-18)


def test_no_balanced_equilibrium_is_reported_as_infinite_multiplier_never_nan():
    p4, w = _point(epsbar=0.04, wbar=2.0)
    lam = F.sweep_speed(p4, [w, 2 * w])
    assert np.all(np.isinf(lam)) and not np.isnan(lam).any()
    res = F.point_stability(p4, w)
    assert not res.exists and res.verdict.startswith('unbalanced')

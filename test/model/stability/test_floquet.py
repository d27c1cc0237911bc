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
            # The accuracy asked of the map (1e-6); DOP853 at rtol = atol = 1e-12 is ~1e-11
            # accurate.
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


def test_the_floquet_rk4_step_is_kernels_rk4_combination_bit_for_bit():
    """The monodromy kernel keeps its own loop over the matrix entries (its kernel set is
    compiled with fastmath, the nonlinear model's is not), but its RK4 step is the package's
    one combination: four steps of monodromy_one equal, bit for bit, the same stages combined by
    kernels/rk4.py's rk4_stage_point and rk4_combine on the flattened [Q, V] (both interpreted,
    so the comparison is of the arithmetic, not of the compiler)."""
    from abb_ros.model.dynamics import kernels
    rng = np.random.default_rng(5)
    nq, nsteps, tau_end = 3, 4, 2 * math.pi
    Mh = rng.normal(0.0, 0.05, (5, nq, nq))
    Mh[0] += np.eye(nq)
    Ch, Kh = rng.normal(0.0, 0.3, (5, nq, nq)), rng.normal(0.0, 1.0, (5, nq, nq))
    Phi = np.empty((2 * nq, 2 * nq))
    F.PY.monodromy_one(Mh, Ch, Kh, tau_end, nsteps, Phi)

    m = 2 * nq
    y = np.concatenate([np.eye(nq, m), np.eye(nq, m, nq)])    # [Q; V], shape (2 nq, m)
    Mw, basis = np.empty((nq, nq)), np.empty(5)
    R = {}
    h = tau_end / nsteps

    def rate(tau, state, out):
        if tau not in R:
            R[tau] = np.empty((nq, m))
            F.PY.accel_matrix(Mh, Ch, Kh, tau, Mw, R[tau], basis)
        F.PY.deriv(R[tau], state[:nq], state[nq:], out[:nq], out[nq:])

    k = [np.empty_like(y) for _ in range(4)]
    yt = np.empty_like(y)
    for step in range(nsteps):
        t0 = step * h
        rate(t0, y, k[0])
        for i, (a, c) in enumerate(((0.5, 0.5), (0.5, 0.5), (1.0, 1.0))):
            kernels.PY.rk4_stage_point(y.ravel(), a * h, k[i].ravel(), yt.ravel())
            rate(t0 + c * h, yt, k[i + 1])
        kernels.PY.rk4_combine(y.ravel(), h, *(ki.ravel() for ki in k), y.ravel())
    np.testing.assert_array_equal(Phi, y)

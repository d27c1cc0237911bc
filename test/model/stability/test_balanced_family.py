"""The family of balanced equilibria for n >= 3 balls: its neutral multipliers removed exactly.

Eq. (26) fixes two combinations of n ball angles, so for n >= 3 the balanced equilibria form a
family of dimension n - 2 (for n = 2 at eps = 0, the rotations), and the linearisation has a
multiplier exactly 1 along each of its directions. The verdict must come from the transverse
multipliers. The reference here is independent of abb_ros.model.stability.linear and of the RK4
monodromy: the in-plane Jacobian is taken by central differences of the *nonlinear* equations
(abb_ros.model.dynamics.equations, itself checked against the sympy derivation from the energies),
the fundamental matrix is integrated by scipy's DOP853 at rtol 1e-10, and the tangent space is
scipy.linalg.null_space of Eq. (26)'s Jacobian. Tolerance 1e-6 on |lambda|: the RK4 monodromy
is within 1e-6 of DOP853 (STEPS_PER_RADIAN's accuracy study), the central differences of a
linear-in-perturbation system with steps 1e-7 add ~1e-9.
"""

import math

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp

from abb_ros.model.dynamics import equations
from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.dynamics.state import StateLayout
from abb_ros.model.jit import Kernels
from abb_ros.model.parameters.params import DriveParams, apply_settings
from abb_ros.model.stability import floquet as F
from abb_ros.model.stability.equilibrium import balanced_equilibrium
from abb_ros.model.stability.family import nearest_member, neutral_count, sample_members


def _drive(n, wbar, **extra):
    return apply_settings(DriveParams(), {'mbar': 0.03, 'zeta': 0.025, 'n': n, 'wbar': wbar,
                                          **extra})


def _in_plane_index(n):
    """Indices of X, Y, gamma, phi_1..phi_n in q = [theta, X, Y, Z, alpha, beta, gamma, phi]."""
    return np.array([1, 2, 6] + [7 + i for i in range(n)])


def _reference_transverse(params, omega, phi_star, h=1e-6, samples=16):
    """Largest |transverse multiplier|, ||Phi V - V||, k and Phi from the nonlinear equations.

    The residual of Eqs. (18)-(24), r = M(q) q'' - f(q, q'), is differentiated by central
    differences about the balanced state at ``samples`` spindle angles over a period: its
    derivatives in q'', q', q are the in-plane M, C, K there. They are trigonometric
    polynomials of order <= 2 in tau = omega t, so their harmonics follow exactly from the
    samples (the fit's residual is asserted); DOP853 then integrates M x'' + C x' + K x = 0.
    """
    n = params.n
    N = 7 + n
    idx = _in_plane_index(n)
    rows = np.array([0, 1, 5] + [6 + i for i in range(n)])
    m = idx.size
    layout = StateLayout(n)
    taus = 2 * math.pi * np.arange(samples) / samples
    mats = np.zeros((3, samples, m, m))
    for s_, tau in enumerate(taus):
        z0 = np.concatenate([layout.pack(theta=tau, deck=np.zeros(6), phi=phi_star,
                                         omega=omega), np.zeros(N)])     # [q, q', q'']
        for j, k in enumerate(idx):
            for which, offset in enumerate((2 * N, N, 0)):   # d/dq'': M, d/dq': C, d/dq: K
                zp, zm = z0.copy(), z0.copy()
                zp[offset + k] += h
                zm[offset + k] -= h
                d = (equations.lagrange_residual(params, zp[:2 * N], zp[2 * N:])
                     - equations.lagrange_residual(params, zm[:2 * N], zm[2 * N:])) / (2 * h)
                mats[which, s_, :, j] = d[rows]
    basis = np.stack([np.ones(samples)] + [f(o * taus) for o in (1, 2)
                                           for f in (np.cos, np.sin)], axis=1)
    harm = np.linalg.lstsq(basis, mats.reshape(3, samples, -1).transpose(1, 0, 2)
                           .reshape(samples, -1), rcond=None)[0]
    fit = basis @ harm
    scale = np.abs(mats).max(axis=(1, 2, 3))
    assert np.all(np.abs(fit - mats.transpose(1, 0, 2, 3).reshape(samples, -1)).reshape(
        samples, 3, -1).max(axis=(0, 2)) < 1e-6 * scale)
    harm = harm.reshape(5, 3, m, m)

    def fun(t, Y):
        b = np.array([1.0, math.cos(omega * t), math.sin(omega * t), math.cos(2 * omega * t),
                      math.sin(2 * omega * t)])
        M, C, K = np.tensordot(b, harm, axes=1)
        Y = Y.reshape(2 * m, 2 * m)
        acc = -np.linalg.solve(M, K @ Y[:m] + C @ Y[m:])
        return np.concatenate([Y[m:], acc]).ravel()

    T = 2 * math.pi / omega
    sol = solve_ivp(fun, (0.0, T), np.eye(2 * m).ravel(), method='DOP853', rtol=1e-10,
                    atol=1e-12)
    Phi = sol.y[:, -1].reshape(2 * m, 2 * m)
    J = np.stack([-np.sin(phi_star), np.cos(phi_star)])
    N_ = scipy.linalg.null_space(J)
    V = np.zeros((2 * m, N_.shape[1]))
    V[3:3 + n] = N_
    W = scipy.linalg.null_space(V.T)
    lam = np.abs(np.linalg.eigvals(W.T @ Phi @ W)).max()
    return lam, np.linalg.norm(Phi @ V - V, axis=0).max(), N_.shape[1], Phi


@pytest.mark.parametrize('n, wbar', [(3, 1.5), (3, 2.7), (4, 2.7),
                                     (10, 2.7)])
def test_transverse_multipliers_match_an_independent_dop853_monodromy(n, wbar):
    params, omega = _drive(n, wbar)
    res = F.point_stability(params, omega)
    ref, ref_invariance, k, Phi = _reference_transverse(params, omega, res.phi_star)
    assert res.neutral == k == n - 2
    assert abs(res.lam_in - ref) < 1e-6, (res.lam_in, ref)
    assert res.invariance < F.INVARIANCE_TOL and ref_invariance < 1e-6
    # the removed multipliers are the ones at 1: the full spectrum holds k of them
    mu = np.abs(np.linalg.eigvals(Phi))
    assert np.sum(np.abs(mu - 1.0) < 1e-6) == k


def test_verdicts_of_three_four_and_ten_balls_are_not_decided_by_round_off():
    """With the family's neutral directions removed, |lambda|max of 3, 4 and 10 balls stays
    below 0.98 (n - 2 neutral modes found), so the verdict never rests on its last bit."""
    for n in (3, 4, 10):
        for wbar in (1.5, 2.7):
            params, omega = _drive(n, wbar)
            res = F.point_stability(params, omega)
            assert res.balanced, (n, wbar, res.lam_in)
            assert res.lam_in < 0.98 and res.neutral == n - 2


def test_neutral_count_is_n_minus_the_rank_of_the_eq26_jacobian():
    """n - 2 for eps > 0; at eps = 0 two balls lose one rank (the pair's rotation is the
    family), while n >= 3 evenly spaced balls keep rank 2 (the rotation is one of the n - 2
    family directions, measured: one multiplier at 1 for three balls at eps = 0)."""
    for n in (2, 3, 4, 10):
        params, omega = _drive(n, 2.7)
        assert F.point_stability(params, omega).neutral == n - 2
    for n, k in ((2, 1), (3, 1), (4, 2)):
        params, omega = _drive(n, 2.7, epsbar=0.0)
        res = F.point_stability(params, omega)
        assert res.neutral == k
        assert res.balanced
        _, _, ref_k, Phi = _reference_transverse(params, omega, res.phi_star)
        assert ref_k == k
        assert np.sum(np.abs(np.abs(np.linalg.eigvals(Phi)) - 1.0) < 1e-6) == k


def test_two_balls_with_eccentricity_are_unchanged_bit_for_bit():
    params, omega = _drive(2, 2.7)
    exists, phi = F.equilibria([params])
    from abb_ros.model.stability.floquet_batch import rate_estimate
    from abb_ros.model.stability.linear import in_plane_harmonics, stack_params
    Mh, Ch, Kh = in_plane_harmonics(stack_params([params]), np.array([omega]), phi)
    steps = F.steps_for(rate_estimate(Mh, Ch, Kh, np.array([omega])), 2 * math.pi)
    old = F.max_multiplier(F.monodromy_batch(Mh, Ch, Kh, np.array([omega]), 2 * math.pi, steps))
    res = F.multipliers_batch([params], [omega])
    assert res.lam[0] == old[0] and res.neutral[0] == 0 and res.invariance[0] == 0.0


def test_tangent_directions_that_are_not_neutral_are_an_error_not_a_verdict():
    """A monodromy that does not keep the family's directions (here: perturbed after the
    integration) fails the self-check with one line saying so."""
    def corrupted(Mh, Ch, Kh, tau_end, nsteps, Phi):
        F.SERIAL.monodromy_many(Mh, Ch, Kh, tau_end, nsteps, Phi)
        Phi += 1e-6

    kern = Kernels({'monodromy_many': corrupted}, compiled=False)
    params, omega = _drive(3, 2.7)
    with pytest.raises(F.FamilyInvarianceError, match='not neutral'):
        F.multipliers_batch([params], [omega], kern=kern)


def test_every_sampled_member_is_balanced_and_has_its_own_multipliers():
    params, omega = _drive(4, 2.7)
    ratio = params.M * params.eps / (params.m * params.R)
    members = sample_members(ratio, 4, 6, first=balanced_equilibrium(params).phi_star)
    assert members.shape == (6, 4)
    from abb_ros.model.stability.equilibrium import eq26_residual
    assert all(eq26_residual(params, phi) < 1e-12 for phi in members)
    fan = np.sort(members[0])
    assert all(np.abs(np.sort(phi) - fan).max() > math.radians(5) for phi in members[1:])
    res = [F.point_stability(params, omega, phi) for phi in members]
    assert all(r.balanced and r.neutral == 2 and r.member == 'given' for r in res)
    lam = [r.lam_in for r in res]
    assert np.ptp(lam) > 0.0    # each member its own multipliers (measured spread 9e-7 here)


def test_nearest_member_lands_on_eq26_next_to_the_balls():
    params, _ = _drive(10, 2.7)
    ratio = params.M * params.eps / (params.m * params.R)
    fan = balanced_equilibrium(params).phi_star
    rng = np.random.default_rng(3)
    near = fan + rng.normal(0.0, 0.02, fan.size)
    member, residual = nearest_member(ratio, near)
    assert residual < 1e-12
    # nearer the balls than the fan they were scattered from (the fan is a member too)
    assert np.linalg.norm(member - near) < 0.5 * np.linalg.norm(fan - near)
    assert neutral_count(member) == 8


def _settled_residual(params, omega, phi0, seconds):
    layout = StateLayout(params.n)
    y0 = layout.pack(theta=0.0, deck=np.zeros(6), phi=phi0, omega=omega)
    sim = Simulation(params, omega, y0=y0)
    sim.advance(int(round(seconds / sim.dt)))
    phi = layout.phi(sim.y)
    ratio = params.M * params.eps / (params.m * params.R)
    return math.hypot(ratio + np.cos(phi).sum(), np.sin(phi).sum())


@pytest.mark.parametrize('wbar, settles', [(2.7, True), (0.7, False)])
def test_ten_balls_from_a_perturbed_member_settle_where_called_balanced(wbar, settles):
    """The nonlinear equations agree with the transverse verdict: at wbar 2.7 (balanced,
    |lambda| 0.971) balls started 2 deg off the fan return to the family; at wbar 0.7
    (unbalanced, 1.67) they leave it."""
    params, omega = _drive(10, wbar)
    res = F.point_stability(params, omega)
    assert res.balanced is settles
    rng = np.random.default_rng(1)
    phi0 = res.phi_star + np.radians(rng.uniform(-2.0, 2.0, 10))
    start = _settled_residual(params, omega, phi0, 0.0)
    end = _settled_residual(params, omega, phi0, 3.0)
    if settles:
        assert end < 1e-3 * start
    else:
        assert end > 10 * start


def test_map_gives_the_best_and_worst_member_around_the_fan(tmp_path):
    """``abb-sim map --members 4``: per point the fan's |lambda|max lies between the best and
    the worst of the members sampled (the fan is one of them), written to the data file."""
    from abb_ros.cli import main as abb_sim
    out = tmp_path / 'map.png'
    code = abb_sim(['map', '--x', 'wbar', '--y', 'zeta', '--set', 'n=4', '--res', '6x4',
                    '--range-x', '0.5:3', '--range-y', '0.02:0.1', '--members', '4',
                    '--no-progress', '--out', str(out)])
    assert code == 0
    with np.load(out.with_suffix('.npz')) as data:
        lam, best, worst = data['lam_max'], data['lam_max_best_member'], \
            data['lam_max_worst_member']
        assert int(data['members']) == 4
    assert np.all(best <= lam) and np.all(lam <= worst)
    assert np.any(worst > best)
    assert abb_sim(['map', '--x', 'wbar', '--y', 'zeta', '--members', '65', '--out',
                    str(out)]) == 2


def test_sweep_verdicts_of_two_three_and_ten_balls_agree_with_the_point_analysis():
    """A sweep over n in {2, 3, 10} (P3 balls, metal washers) reports, per drive, the transverse
    verdict of point_stability (not the neutral modes' |lambda| = 1, which would call balanced
    three-ball drives unbalanced), and its neutral-mode count."""
    from abb_ros.sweep.compute import compute_partition, partition_params
    from abb_ros.sweep.sampling import draw_samples
    from abb_ros.sweep.spec import parse_spec
    doc = {'parameters': {'n': {'dist': 'grid', 'values': [2, 3, 10]}},
           'compute': {'stability': {'wbar': [1.5, 2.7]}}, 'operating_wbar': 2.7,
           'base': {'c': 0.66}}
    spec = parse_spec(doc)
    samples = draw_samples(spec)
    out = compute_partition(spec, 0, samples)
    plist = partition_params(spec, samples)
    assert [p.n for p in plist] == [2, 3, 10]
    assert out['neutral_modes'].tolist() == [0, 1, 8]
    for i, p in enumerate(plist):
        res = F.point_stability(p, spec.operating_omega)
        assert out['lam_in_op'][i] == pytest.approx(res.lam_in, abs=1e-12)
        assert bool(out['balanced_op'][i]) is res.balanced is True

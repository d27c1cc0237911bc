"""The reduced in-plane monodromy of n > 3 balls (floquet_reduction.py) against the whole one."""

import math

import numpy as np
import pytest

from abb_ros.model.parameters.params import DriveParams, apply_settings
from abb_ros.model.stability import floquet as F
from abb_ros.model.stability import floquet_reduction as reduction
from abb_ros.model.stability.family import sample_members
from abb_ros.model.stability.linear import PeriodicSystem, in_plane_harmonics, stack_params

TABLE1 = DriveParams()


def _points(n, count, seed):
    rng = np.random.default_rng([seed, n])
    pts = [apply_settings(TABLE1, {'n': n, 'zeta': rng.uniform(0.005, 0.15),
                                   'mbar': rng.uniform(0.001, 0.12),
                                   'wbar': rng.uniform(0.2, 3.5)}) for _ in range(count)]
    return [p for p, _ in pts], np.array([w for _, w in pts])


@pytest.mark.parametrize('n', [4, 5, 10])
def test_reduced_multipliers_equal_the_whole_system_kernel_within_1e_9(n):
    """Give the same |lambda|max, neutral count and verdict as the (3 + n)-coordinate kernel.

    The reduction is exact and RK4 commutes with the change of variables, so the two differ by
    round-off only (measured 1e-14); 1e-9 is the claim of the maps.
    """
    plist, omegas = _points(n, 60, 1)
    new = F.multipliers_batch(plist, omegas, reduce=True)
    old = F.multipliers_batch(plist, omegas, reduce=False)
    ok = np.isfinite(old.lam)
    assert ok.sum() > 40
    assert np.array_equal(np.isfinite(new.lam), ok)
    assert np.abs(new.lam[ok] - old.lam[ok]).max() < 1e-9
    assert np.array_equal(new.neutral, old.neutral)
    assert np.array_equal(new.lam < 1.0, old.lam < 1.0)
    assert new.invariance.max() < F.INVARIANCE_TOL


def test_reduction_holds_at_any_member_of_the_balanced_family():
    """Agree within 1e-9 at random members of the family, not only at the symmetric fan."""
    n = 6
    p, w = apply_settings(TABLE1, {'n': n, 'zeta': 0.04, 'mbar': 0.05, 'wbar': 2.2})
    phi = sample_members(p.M * p.eps / (p.m * p.R), n, 12)
    assert len(phi) >= 8
    args = ([p] * len(phi), np.full(len(phi), w), 'in', phi)
    new = F.multipliers_batch(*args, reduce=True)
    old = F.multipliers_batch(*args, reduce=False)
    np.testing.assert_allclose(new.lam, old.lam, rtol=0, atol=1e-9)
    assert np.array_equal(new.neutral, old.neutral)


def test_decoupled_ball_directions_meet_neither_deck_nor_reduced_coordinates():
    """In the basis [Q, Q_perp] every harmonic of M, C, K is block diagonal (to 1e-12 relative).

    The ball-ball blocks there are m R^2 I, D I and 0, as the module's argument says.
    """
    n = 7
    plist, omegas = _points(n, 5, 3)
    phi = np.random.default_rng(4).uniform(-math.pi, math.pi, (5, n))
    H = in_plane_harmonics(stack_params(plist), omegas, phi)
    Q = reduction.ball_basis(phi)
    full = np.linalg.qr(np.concatenate([Q, np.random.default_rng(5).normal(size=(5, n, n - 3))],
                                       axis=-1))[0]
    T = np.zeros((5, 1, 3 + n, 3 + n))
    T[:, 0, :3, :3] = np.eye(3)
    T[:, 0, 3:, 3:] = full
    p = stack_params(plist)
    mR2, D = p.m * p.R ** 2, p.D
    for Hx, diag in zip(H, (mR2, D, 0 * D)):
        Ht = np.swapaxes(T, -1, -2) @ Hx @ T
        scale = np.abs(Hx).max()
        assert np.abs(Ht[..., :6, 6:]).max() < 1e-12 * scale
        assert np.abs(Ht[..., 6:, :6]).max() < 1e-12 * scale
        tail = Ht[:, 0, 6:, 6:] - diag[:, None, None] * np.eye(n - 3)
        assert np.abs(tail).max() < 1e-12 * scale
        assert np.abs(Ht[:, 1:, 6:, 6:]).max() < 1e-12 * scale


@pytest.mark.parametrize('steps', [32, 57])
def test_complement_multiplier_is_the_rk4_kernel_multiplier_of_a_decoupled_ball(steps):
    """Equal, to round-off, the monodromy kernel's multiplier of m R^2 psi'' + D psi' = 0."""
    p = TABLE1
    omega = 500.0
    one = lambda v: np.array([[[v]], [[0.0]], [[0.0]]])  # noqa: E731  harmonic 0 only
    system = PeriodicSystem(one(p.m * p.R ** 2), one(p.D * 40.0), one(0.0), omega,
                            2 * math.pi / omega, ('psi',))
    Phi = F.monodromy_batch(system.M[None], system.C[None], system.K[None], [omega],
                            2 * math.pi, steps)[0]
    a = p.D * 40.0 / (omega * p.m * p.R ** 2)
    rho = reduction.complement_multiplier(a, 2 * math.pi, steps)
    assert sorted(np.abs(np.linalg.eigvals(Phi))) == pytest.approx([float(rho), 1.0], abs=1e-13)
    assert abs(rho - math.exp(-a * 2 * math.pi)) < 1e-3     # and RK4 is near the exact decay

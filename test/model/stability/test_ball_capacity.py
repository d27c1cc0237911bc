"""Balls with a size cancel less than n m R: the packed chain's capacity bounds Eq. (26).

Balls that touch (r_ball > 0, contact on) cannot come closer than s = 2 asin(r_ball / R), so
the largest imbalance they cancel is that of the packed chain, sin(n s / 2) / sin(s / 2) m R.
Checked against a brute-force search over ball configurations, and against the nonlinear
equations with Hertz contact just below and just above it.
"""

import math

import numpy as np
import pytest

from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.dynamics.state import StateLayout
from abb_ros.model.parameters.ball_materials import with_steel_balls
from abb_ros.model.parameters.params import DriveParams, ParamError, apply_settings
from abb_ros.model.stability import floquet as F
from abb_ros.model.stability.equilibrium import (
    balanced_equilibrium,
    ball_capacity,
    epsbar_lim,
    min_spacing,
)


def _steel(n):
    base, omega = apply_settings(DriveParams(), {'n': n, 'wbar': 2.7, 'zeta': 0.025})
    return with_steel_balls(base), omega


def _at(params, fraction):
    """params with the imbalance M eps = fraction x the capacity's."""
    return params.replace(eps=fraction * ball_capacity(params) * params.m * params.R / params.M)


def test_ten_steel_balls_of_0_156_g_cancel_eight_point_oh_five():
    """0.156 g steel balls (r 1.68 mm) on R = 15 mm: packed 12.86 deg apart, C = 8.05."""
    p = with_steel_balls(DriveParams(n=10, m=0.156e-3))
    assert math.degrees(p.contact_separation) == pytest.approx(12.86, abs=0.01)
    assert ball_capacity(p) == pytest.approx(8.05, abs=0.01)


@pytest.mark.parametrize('n', [2, 3, 10])
def test_capacity_is_the_largest_resultant_of_balls_kept_apart(n):
    """Random configurations with every gap >= s never beat the packed chain (2e4 draws)."""
    p, _ = _steel(n)
    s = p.contact_separation
    rng = np.random.default_rng(n)
    free = 2 * math.pi - n * s
    gaps = s + free * rng.dirichlet(np.full(n, 0.3), size=20000)
    phi = np.cumsum(gaps, axis=1)
    best = np.abs(np.exp(1j * phi).sum(axis=1)).max()
    assert best <= ball_capacity(p) + 1e-12
    assert best > ball_capacity(p) - 0.05 * n


def test_fan_keeps_the_balls_apart_up_to_the_capacity_and_none_exists_beyond():
    p, omega = _steel(10)
    below = balanced_equilibrium(_at(p, 0.999))
    assert below.exists
    assert min_spacing(below.phi_star) >= p.contact_separation
    above = balanced_equilibrium(_at(p, 1.001))
    assert not above.exists
    assert 'the balls touch before they cancel the imbalance' in above.reason
    exists, _ = F.equilibria([_at(p, 0.999), _at(p, 1.001)])
    assert exists.tolist() == [True, False]
    res = F.point_stability(_at(p, 1.001), omega)
    assert res.verdict == 'unbalanced (no balanced equilibrium)'
    assert epsbar_lim(p) == pytest.approx(ball_capacity(p) * p.m / p.M)


def test_without_contact_the_point_mass_capacity_is_unchanged():
    p, _ = _steel(10)
    off = p.replace(contact_E=0.0)
    assert ball_capacity(off) == 10.0
    assert balanced_equilibrium(_at(p, 1.05).replace(contact_E=0.0)).exists


def test_a_given_member_with_overlapping_balls_is_refused():
    """The point-mass fan at M eps = 2.95 m R solves Eq. (26) but puts three steel balls
    closer than their contact separation (capacity 2.90): refused, naming phi_star."""
    p, _ = _steel(3)
    q = p.replace(eps=2.95 * p.m * p.R / p.M)
    fan = balanced_equilibrium(q.replace(contact_E=0.0)).phi_star
    assert min_spacing(fan) < q.contact_separation
    with pytest.raises(ParamError, match="'phi_star'.*contact separation"):
        balanced_equilibrium(q, fan)


@pytest.mark.parametrize('fraction, balances', [(0.97, True), (1.03, False)])
def test_contact_run_balances_just_below_the_packed_capacity_only(fraction, balances):
    """Three steel balls with Hertz contact at wbar 2.7 from a start 30 deg apart: below the
    capacity they settle 24.9 deg apart with rbar -> 0 (measured 1e-14); above it they pack
    at the contact separation and the deck keeps whirling (rbar ~ 3e-4)."""
    p, omega = _steel(3)
    q = _at(p, fraction)
    layout = StateLayout(3)
    y0 = layout.pack(theta=0.0, deck=np.zeros(6), phi=np.radians([150.0, 180.0, -150.0]),
                     omega=omega)
    sim = Simulation(q, omega, y0=y0)
    sim.advance(40000)
    tail = []
    for _ in range(10):
        sim.advance(100)
        tail.append(layout.rbar(sim.y, q.R))
    if balances:
        assert max(tail) < 1e-9
        assert min_spacing(layout.phi(sim.y)) > q.contact_separation
    else:
        assert min(tail) > 1e-5
        assert min_spacing(layout.phi(sim.y)) < q.contact_separation + math.radians(0.1)

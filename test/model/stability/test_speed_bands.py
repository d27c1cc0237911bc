"""abb_ros.model.stability.speed_bands: |lambda|max against speed, unbalanced bands and the
verdict.

The drive is the paper's P1-P3 drive of Fig. 7(b) (metal washers c = 0.66 kg/s, mbar = 0.03,
Table 1 otherwise); the claims are Section 5's: unbalanced below the translational natural
frequency (P1, wbar 0.8), inside the band near the rotational natural frequency (P2, 2.18),
balanced at P3 (2.7), and no balanced equilibrium when M eps > n m R (Fig. 6).
"""

import math

import numpy as np
import pytest

from abb_ros.model.parameters.params import DriveParams, ParamError
from abb_ros.model.stability.floquet import point_stability
from abb_ros.model.stability.speed_bands import (
    BAND_GUARD_WBAR,
    ERROR,
    MARGIN_WARN,
    OK,
    WARN,
    SpeedTable,
    assess,
    refine,
    rpm,
    speed_table,
    unbalanced_bands,
)

P3 = DriveParams(c=0.66, m=0.03 * 0.026)
W0 = P3.omega0


@pytest.fixture(scope='module')
def table():
    return speed_table(P3, 1500.0)


def _lam(params, omega):
    s = point_stability(params, omega)
    return max(s.lam_in, s.lam_out)


def test_bands_lie_below_omega0_and_around_the_rotational_natural_frequency(table):
    kinds = [(b.kind, b.lo / W0, b.hi / W0) for b in table.bands]
    first = table.bands[0]
    assert first.lo == 0.0 and first.hi > W0 and first.kind == 'translational', kinds
    p2 = [b for b in table.bands if b.contains(2.18 * W0)]
    assert len(p2) == 1 and p2[0].kind == 'rotational', kinds
    assert not any(b.contains(2.7 * W0) for b in table.bands), kinds


def test_band_edges_are_where_the_largest_multiplier_crosses_one(table):
    """Edges come from linear interpolation between table points 5 rad/s apart; 1 rad/s on
    either side of every edge the exact |lambda|max is already on the right side of 1
    (measured: edge errors below 0.5 rad/s)."""
    for band in table.bands:
        for edge, inside in ((band.lo, +1.0), (band.hi, -1.0)):
            if edge in (0.0, table.omegas[-1]):
                continue
            assert _lam(P3, edge + inside * 1.0) >= 1.0, band
            assert _lam(P3, edge - inside * 1.0) < 1.0, band


def test_interpolated_multipliers_match_the_exact_ones_away_from_the_bands(table):
    """Away from the band peaks |lambda|max is smooth in omega: linear interpolation over
    5 rad/s is within 1e-4 (measured 1.3e-6)."""
    rng = np.random.default_rng(7)
    omegas = [w for w in rng.uniform(10.0, 1490.0, 30)
              if all(b.distance(w) > 0.1 * W0 for b in table.bands)]
    assert len(omegas) > 10
    for w in omegas:
        s = point_stability(P3, w)
        lam_in, lam_out = table.at(w)
        assert lam_in == pytest.approx(s.lam_in, abs=1e-4)
        assert lam_out == pytest.approx(s.lam_out, abs=1e-4)


def test_p1_is_an_error_below_the_translational_natural_frequency(table):
    a = assess(table, 0.8 * W0)
    assert a.level == ERROR and 'below translational natural frequency' in a.message
    assert a.margin < 0


def test_p2_is_an_error_inside_the_band_near_the_rotational_natural_frequency(table):
    a = assess(table, 2.18 * W0)
    assert a.level == ERROR, a.message
    assert 'inside an unbalanced band near the rotational natural frequency' in a.message


def test_p3_is_balanced_and_stable_with_the_corrected_eq34_angles(table):
    """Eq. (26) at mbar 0.03: cos phi* = -M eps / (2 m R), |phi*| = 106.13 deg."""
    a = assess(table, 2.7 * W0)
    assert a.level == OK and a.message.startswith('balanced and stable, margin'), a.message
    assert 0 < a.margin == pytest.approx(1 - max(table.at(2.7 * W0)), abs=0)
    expected = math.degrees(math.acos(-P3.M * P3.eps / (2 * P3.m * P3.R)))
    phi = sorted(float(x) for x in a.values['phi_star_deg'].split(','))
    assert phi == pytest.approx([-expected, expected], abs=0.01)  # printed to 0.01 deg


def test_stable_point_close_to_a_band_is_a_warning(table):
    band = [b for b in table.bands if b.kind == 'rotational'][-1]
    a = assess(table, band.hi + 0.5 * BAND_GUARD_WBAR * W0)
    assert a.level == WARN and 'unbalanced band near the rotational' in a.message, a.message


def test_exact_point_replaces_the_interpolated_multipliers(table):
    w = 2.7 * W0
    exact = refine(table, w)
    a = assess(table, w, exact)
    assert a.values['lambda_in'] == exact.lam_in and a.values['source'].startswith('exact')


def test_imbalance_beyond_the_balls_capacity_is_an_error_naming_it():
    """Fig. 6: eps_lim = n m R / M = 0.9 mm; 10 % more has no balanced equilibrium."""
    eps_lim = P3.n * P3.m * P3.R / P3.M
    t = speed_table(P3.replace(eps=1.1 * eps_lim), 1500.0)
    a = assess(t, 2.7 * W0)
    assert not t.exists and t.bands == ()
    assert a.level == ERROR and "imbalance exceeds the balls' capacity" in a.message
    assert a.margin == -math.inf and a.values['balanced_equilibrium_exists'] is False


@pytest.mark.parametrize('omega', [math.nan, math.inf, -1.0])
def test_a_speed_that_is_not_a_finite_nonnegative_number_is_an_error(table, omega):
    assert assess(table, omega).level == ERROR


def test_margin_rule_on_a_synthetic_table():
    """The WARN threshold itself, with flat multipliers and no band."""
    def flat(lam):
        omegas = np.linspace(10.0, 1000.0, 5)
        return SpeedTable(P3, 1000.0, omegas, np.full(5, lam), np.full(5, 0.5), True,
                          np.zeros(2), '', {'Y': W0}, ())
    assert assess(flat(1.0 - 2 * MARGIN_WARN), 500.0).level == OK
    small = assess(flat(1.0 - MARGIN_WARN / 2), 500.0)
    assert small.level == WARN and 'small margin' in small.message


def test_band_edges_by_linear_interpolation_of_lambda_minus_one():
    """Worked by hand: crossings at 1 + 0.1/0.2, 3 + 0.1/0.15 and 4 + 0.05/0.1."""
    lam = np.array([1.2, 1.1, 0.9, 0.9, 1.05, 0.95])
    bands = unbalanced_bands(np.arange(6.0), lam, {'Y': 1.0, 'gamma': 4.0})
    edges = [e for b in bands for e in (b.lo, b.hi)]
    assert edges == pytest.approx([0.0, 1.5, 3 + 2 / 3, 4.5], abs=1e-12)
    assert [b.near for b in bands] == ['Y', 'gamma']


def test_speed_range_must_be_positive():
    with pytest.raises(ParamError, match='max_spindle_speed'):
        speed_table(P3, 0.0)


def test_rpm():
    assert rpm(2 * math.pi) == pytest.approx(60.0)

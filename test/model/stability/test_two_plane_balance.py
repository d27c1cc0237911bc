"""Two-plane balancing in closed form (abb_ros.model.stability.two_plane, Section 5's pointer).

The independent check is the deck's own rows (abb_ros.model.dynamics.equations): at rest with
the spindle turning, the rows' forcing is a sum over the point masses, so the two races'
contributions (race 1 with the rotor, race 2 alone) add; the closed form must leave the sum at
zero to round-off (1e-12 of the imbalance force M eps omega^2 and of its moment).
"""

import numpy as np
import pytest

from abb_ros.model.dynamics.equations import lagrange_residual
from abb_ros.model.dynamics.state import PHI, THETA, n_coords
from abb_ros.model.parameters.params import DriveParams, ParamError, apply_settings
from abb_ros.model.stability import two_plane

P3 = DriveParams(c=0.66, m=0.03 * 0.026)
OMEGA = 811.0


def deck_forcing(params, phi, theta=0.3):
    """Return the deck rows' forcing at rest (X, Y, Z, alpha, beta, gamma), balls at phi."""
    N = n_coords(params.n)
    y = np.zeros(2 * N)
    y[THETA], y[PHI:N], y[N + THETA] = theta, phi, OMEGA
    return -lagrange_residual(params, y, np.zeros(N))[:6]


def second_race_alone(params, race):
    """The drive's deck with race 2's balls only: no imbalance, the race at its height."""
    return apply_settings(params, {'n': race.n, 'm': race.m, 'R': race.R, 'z_B': race.z,
                                   'eps': 0.0})[0]


@pytest.mark.parametrize('heights,race2', [
    ({'z_G': 0.001}, two_plane.Race(2, 0.03 * 0.026, 0.015, 0.004)),
    ({'z_G': 0.003, 'z_B': -0.002, 'z_P': 0.005}, two_plane.Race(3, 0.002, 0.012, 0.006)),
])
def test_closed_form_holds_the_deck_at_rest_to_round_off(heights, race2):
    p = apply_settings(P3, heights)[0]
    bal = two_plane.two_plane_balance(p, race2)
    one = deck_forcing(p, bal.phi[0])
    two = deck_forcing(second_race_alone(p, race2), bal.phi[1])
    force = p.M * p.eps * OMEGA ** 2
    assert np.abs(one + two).max() <= 1e-12 * force
    assert np.abs(one[3:5]).max() > 1e-3 * force * abs(p.z_G - p.z_B)   # race 1 alone tilts


def test_resultants_cancel_force_and_couple_and_the_balls_give_them():
    p = apply_settings(P3, {'z_G': 0.002, 'z_B': 0.0005})[0]
    bal = two_plane.two_plane_balance(p, two_plane.Race(2, p.m, p.R, 0.004))
    U_s = p.M * p.eps
    assert sum(bal.B) == pytest.approx(-U_s, rel=1e-14)
    assert bal.races[0].z * bal.B[0] + bal.races[1].z * bal.B[1] == pytest.approx(
        -U_s * p.z_G, rel=1e-14)
    for race, B, phi in zip(bal.races, bal.B, bal.phi):
        assert race.m * race.R * np.exp(1j * phi).sum() == pytest.approx(B, abs=1e-18)


def test_one_race_leaves_the_couple_of_its_lever():
    p = apply_settings(P3, {'z_G': 0.002, 'z_B': 0.0005})[0]
    assert two_plane.residual_couple(p) == pytest.approx(p.M * p.eps * 0.0015)
    assert two_plane.residual_couple(P3) == 0.0


def test_a_race_in_g_plane_leaves_no_couple_and_no_second_race_to_suggest():
    """Exactly zero, not the rounding of M eps z_G - z_B M eps: at 2001 common heights the
    analysis must not suggest a second race (before the lever was formed first, 684 of them
    left a couple of ~1e-25 kg m^2 and a useless race 10 mm away)."""
    for z in np.linspace(-0.01, 0.01, 2001):
        p = apply_settings(P3, {'z_G': float(z), 'z_B': float(z), 'eps': 3.3e-4})[0]
        assert two_plane.residual_couple(p) == 0.0
        assert two_plane.second_race(p) == {}


def test_the_mirrored_race_carries_half_the_imbalance():
    p = apply_settings(P3, {'z_G': 0.001})[0]
    bal = two_plane.mirror_race(p)
    assert bal.races[1].z == pytest.approx(0.002)
    assert bal.B[0] == pytest.approx(bal.B[1]) and abs(bal.B[1]) == pytest.approx(
        p.M * p.eps / 2)
    assert two_plane.mirror_race(apply_settings(P3, {'z_G': 0.004, 'z_B': 0.004})[0]) is None


def test_a_plane_beyond_its_capacity_is_refused_naming_it():
    """Race 2 just above race 1 must carry M eps (z_G - z_1) / (z_2 - z_1) and race 1 nearly as
    much: ten and nine times the imbalance, more than two balls hold (race 1, ``n``, is named
    first); a race 2 of light balls at 4 mm cannot hold its quarter."""
    p = apply_settings(P3, {'z_G': 0.001})[0]
    with pytest.raises(ParamError, match="'n'.*capacity"):
        two_plane.two_plane_balance(p, two_plane.Race(2, p.m, p.R, 0.0001))
    with pytest.raises(ParamError, match="'race2.n'.*capacity"):
        two_plane.two_plane_balance(p, two_plane.Race(2, 1e-5, p.R, 0.004))
    with pytest.raises(ParamError, match="'race2.z'"):
        two_plane.two_plane_balance(p, two_plane.Race(2, p.m, p.R, 0.0))

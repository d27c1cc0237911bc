"""The state layout (model/dynamics/state.py): named slices, packing, batches, wrapped angles."""

import math

import numpy as np
import pytest

from abb_ros.model.dynamics.state import (
    DECK,
    PHI,
    THETA,
    StateLayout,
    n_coords,
    wrap_angle,
    wrap_degrees,
)


@pytest.mark.parametrize('n', [0, 2, 10])
def test_named_slices_cover_the_state_once_in_the_order_of_q_then_q_dot(n):
    """theta, the deck, the balls and then their rates tile y = [q, q'] exactly once, in that
    order, and N = 7 + n."""
    s = StateLayout(n)
    y = np.arange(s.size, dtype=float)
    parts = np.concatenate([[s.theta(y)], s.deck(y), s.phi(y), [s.omega(y)], s.deck_rates(y),
                            s.phi_rates(y)])
    np.testing.assert_array_equal(parts, y)
    assert s.N == n_coords(n) == 7 + n and (THETA, DECK, PHI) == (0, 1, 7)
    assert len(s.coord_names()) == s.N and s.coord_names()[PHI - 1] == 'gamma'


def test_pack_puts_each_value_where_the_accessor_reads_it():
    """pack(...) followed by each accessor returns what was packed, and the rates not given are
    zero."""
    s = StateLayout(3)
    y = s.pack(theta=0.5, deck=range(1, 7), phi=[7, 8, 9], omega=300.0, phi_rates=[1, 2, 3])
    assert s.theta(y) == 0.5 and s.omega(y) == 300.0
    np.testing.assert_array_equal(s.deck(y), range(1, 7))
    np.testing.assert_array_equal(s.phi(y), [7, 8, 9])
    np.testing.assert_array_equal(s.phi_rates(y), [1, 2, 3])
    assert not s.deck_rates(y).any()


def test_accessors_work_on_a_batch_of_states_and_rbar_is_translation_over_race_radius():
    """The accessors take a batch of states (shape (k, 2N)), and rbar is |(X, Y, Z)| / R: a 3-4-12
    mm translation on a 13 mm race is 1."""
    s = StateLayout(2)
    ys = np.zeros((4, s.size))
    ys[:, DECK:DECK + 3] = [3e-3, 4e-3, 12e-3]
    np.testing.assert_allclose(s.rbar(ys, 0.013), np.full(4, 1.0))
    assert s.phi(ys).shape == (4, 2) and s.omega(ys).shape == (4,)


def test_shared_layout_per_n_is_immutable_and_equal_to_a_new_one():
    """StateLayout.of(n) is one shared instance, equal to a new StateLayout(n), and cannot be
    changed."""
    assert StateLayout.of(2) is StateLayout.of(2) and StateLayout.of(2) == StateLayout(2)
    with pytest.raises(AttributeError):
        StateLayout(2).n = 3


def test_wrapped_ball_angles_lie_in_minus_pi_excluded_to_pi_included():
    """wrap_angle maps every angle into (-pi, pi] (-pi and 3 pi become pi); wrap_degrees is the
    same in degrees."""
    phi = np.array([-math.pi, math.pi, 3 * math.pi, 0.1 - 2 * math.pi, 7.0])
    got = wrap_angle(phi)
    np.testing.assert_allclose(got, [math.pi, math.pi, math.pi, 0.1, 7.0 - 2 * math.pi])
    np.testing.assert_allclose(wrap_degrees(phi), np.degrees(got))

"""A second race (docs/equations.md, F7) against the energies, and two-plane balancing in a run.

The paper's Section 2: a drive whose mass centre G does not lie in the balls' plane is balanced
perfectly only by two ABBs on different planes. ``race2.n`` balls of mass race2.m on a race of
pitch radius race2.R, drag race2.D, at height race2.z join race 1's n balls; the reference is
the project's sympy derivation (test/lagrange_sympy.py) with the second race's masses, radii,
drags and heights in the energies of Eqs. (11)-(16), expanded to first order in the deck
coordinates like the heights' (test_heights_vs_lagrange.py).
"""

import math

import lagrange_sympy as L
import numpy as np
import pytest
from test_equations_vs_lagrange import ROUND_OFF, at_scale, random_state, scales
from test_heights_vs_lagrange import settled

from abb_ros.app import run_settings
from abb_ros.app.headless import run_scenario
from abb_ros.io.files.scenario import load_scenario
from abb_ros.model.dynamics import equations
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import Simulation
from abb_ros.model.dynamics.spindle import TorqueMotor
from abb_ros.model.dynamics.state import StateLayout
from abb_ros.model.parameters.params import DriveParams, ParamError
from abb_ros.model.stability import coupled, two_plane

TWO_RACES = dict(z_P=0.012, z_G=0.004, z_B=-0.003, race2_m=0.6e-3, race2_R=0.018,
                 race2_D=7e-6, race2_z=0.009)
"""A second race unlike the first in every value, at heights of an optical drive's size."""


def two_race_states(n, n2, seed):
    """Yield 6 random (params, y, qdd, deck) of n + n2 balls and theta'' != 0."""
    params = DriveParams(n=n, race2_n=n2, **TWO_RACES)
    rng = np.random.default_rng(seed + 10 * n + n2)
    for _ in range(6):
        yield (params, *random_state(params, rng, rng.uniform(-2000.0, 2000.0)))


@pytest.mark.parametrize('n, n2', [(1, 1), (2, 1), (2, 2)])
def test_two_race_rows_are_the_first_order_expansion_of_the_energies(n, n2):
    """lagrange_residual with two races equals the energies' first-order equations to round-off.

    Both are first order in the deck coordinates, so they agree at any deck scale; ROUND_OFF as
    in test_equations_vs_lagrange.py. Each ball row is scaled by its own m_i R_i^2 omega^2.
    """
    for params, y, qdd, deck in two_race_states(n, n2, seed=800):
        y, qdd = at_scale(y, qdd, deck, 0.05)
        err = equations.lagrange_residual(params, y, qdd) - L.first_order_residual(params, y, qdd)
        assert np.max(np.abs(err / scales(params, y[7 + n + n2]))) < ROUND_OFF


@pytest.mark.parametrize('n, n2', [(1, 2), (2, 2)])
def test_two_race_accelerations_solve_the_rows(n, n2):
    """q'' of the kernels (each race's own m R^2 eliminated) makes every residual vanish (1e-10,
    the round-off of the coupled 6 + n system as for the heights)."""
    for params, y, qdd, deck in two_race_states(n, n2, seed=900):
        y, _ = at_scale(y, qdd, deck, 0.05)
        got = equations.accelerations(params, y)
        res = equations.lagrange_residual(params, y, got)
        assert np.max(np.abs(res / scales(params, y[7 + n + n2]))) < 1e-10


def test_an_empty_second_race_leaves_the_papers_run_bit_for_bit():
    """race2.n = 0 with race 2's other values set: the same state, to the bit, as the paper's."""
    paper = Simulation(DriveParams(), 811.2, 1e-5)
    unused = Simulation(DriveParams(race2_m=1e-3, race2_R=0.02, race2_D=1e-5), 811.2, 1e-5)
    paper.advance(3000)
    unused.advance(3000)
    assert paper.y.tobytes() == unused.y.tobytes()


def test_a_second_race_of_race_1s_balls_in_its_plane_moves_like_more_balls_in_race_1():
    """Two races that are one (same m, R, D, z): the state equals race 1 holding n + race2.n
    balls (1e-12 of the scale: the sums are formed in another order)."""
    phi = np.radians([-110.0, 100.0, 30.0])
    one = Simulation(DriveParams(n=3), 811.2, 1e-5, y0=initial_state(DriveParams(n=3), 811.2,
                                                                       phi))
    two = DriveParams(n=2, race2_n=1)
    split = Simulation(two, 811.2, 1e-5, y0=initial_state(two, 811.2, phi))
    one.advance(3000)
    split.advance(3000)
    assert np.allclose(split.y, one.y, rtol=1e-12, atol=1e-15)


def test_bad_second_races_are_refused_naming_the_parameter():
    """Negative, fractional, too many, non-finite; with the ball terms or torque mode."""
    for bad, text in ((dict(race2_n=-1), "'race2.n'"), (dict(race2_n=1.5), "'race2.n'.*integer"),
                      (dict(n=40, race2_n=30), "'race2.n'.*at most 24"),
                      (dict(race2_n=2, race2_m=float('nan')), "'race2.m'"),
                      # m R^2 of 1e-300 would make the step non-finite
                      (dict(race2_n=2, race2_m=1e-300), "'race2.m'.*race 1's m"),
                      (dict(race2_n=2, race2_R=1e-200), "'race2.R'.*race 1's R"),
                      (dict(race2_n=2, race2_z=2.0), "'race2.z'"),
                      (dict(race2_n=2, r_ball=1e-3, contact_E=2e11), "'race2.n'.*contact_E")):
        with pytest.raises(ParamError, match=text):
            DriveParams(**bad)
    with pytest.raises(ParamError, match="'race2.n'.*torque"):
        Simulation(DriveParams(race2_n=2, race2_z=0.01), 300.0, spindle=TorqueMotor())
    with pytest.raises(ParamError, match='phi0.*race2.n = 2 \\+ 1'):
        initial_state(DriveParams(race2_n=1), 800.0, [0.0, 1.0])


P3_TWO_RACES = {'z_G': 1e-3, 'race2.n': 2, 'race2.z': 2e-3}
"""P3 with G 1 mm above race 1 and race 2 mirrored about G: two balls each, M eps / 2 each."""


def two_race_run(duration):
    """Return (params, omega, t, tilt sqrt(alpha^2 + beta^2), final ball angles) of P3."""
    scenario, _ = run_settings.apply_settings(load_scenario('p3'), P3_TWO_RACES)
    scenario.duration = duration
    result = run_scenario(scenario)
    layout = StateLayout.of(scenario.params.n_balls)
    deck = layout.deck(result.y)
    return (scenario.params, scenario.omega, result.t, np.hypot(deck[:, 3], deck[:, 4]),
            layout.phi(result.y[-1]))


@pytest.fixture(scope='module')
def forty_seconds():
    return two_race_run(40.0)


@pytest.mark.slow
def test_p3_two_races_on_either_side_of_g_cancel_the_couple_one_race_leaves(
        abb_sim, tmp_path, forty_seconds):
    """G 1 mm above race 1: one race leaves 1.34 mrad of tilt after 6 s and keeps it; with the
    mirrored second race the balls walk (slowly: the couple's mode decays with a time constant
    of ~3.8 s) to the closed form's angles and the tilt goes (measured 1.9e-7 rad at 40 s,
    the balls within 0.01 deg of the closed form)."""
    one = settled(abb_sim, tmp_path, 'z_G=0.001')
    params, _, t, tilt, phi = forty_seconds
    closed = np.concatenate(two_plane.drive_balance(params).phi)
    assert one['tilt_rad'] > 1e-3
    assert tilt[t > 39.9].max() < 1e-3 * one['tilt_rad']
    for race in (slice(0, 2), slice(2, 4)):
        gap = (np.sort(np.mod(phi[race], 2 * np.pi)) - np.sort(np.mod(closed[race], 2 * np.pi)))
        assert np.degrees(np.abs(gap)).max() < 0.05


@pytest.mark.slow
def test_the_couples_slow_decay_is_the_coupled_linearisations_lam_max(forty_seconds):
    """The tilt's decay rate between 28 s and 40 s (the slowest mode alone by then) equals
    ln(lam_max) / T of the coupled linearisation about the two-plane balance (measured
    -0.26549 and -0.26529 1/s, 0.08 % apart; 1 % allows for the faster modes' remains)."""
    params, omega, t, tilt, _ = forty_seconds
    lam = coupled.coupled_stability(params, omega).lam_max
    early, late = tilt[(t > 27.9) & (t <= 28.0)].max(), tilt[t > 39.9].max()
    measured = math.log(late / early) / 12.0
    assert measured == pytest.approx(math.log(lam) / (2 * math.pi / omega), rel=0.01)


def test_two_races_in_gs_plane_share_the_force_and_leave_their_family_neutral():
    """Two races in G's plane balance any split of the force: the member shares it by
    capacity, and the family's tangents (4 balls, 2 conditions: 2 directions) are neutral in
    the coupled linearisation to its finite-difference accuracy (INVARIANCE_TOL)."""
    params = DriveParams(race2_n=2)
    balance = two_plane.drive_balance(params)
    assert balance.B[0] == pytest.approx(balance.B[1], rel=1e-12)
    assert two_plane.balance_residual(params, np.concatenate(balance.phi)) < 1e-12
    stability = coupled.coupled_stability(params, 811.2)
    assert stability.neutral == 2 and stability.invariance < coupled.INVARIANCE_TOL


def test_races_in_one_plane_apart_from_g_cannot_balance_and_say_why():
    """G 1 mm above two races that share a plane: no balance, the reason names race2.z."""
    with pytest.raises(ParamError, match="'race2.z'.*cannot cancel a couple"):
        two_plane.drive_balance(DriveParams(z_G=0.001, race2_n=2))

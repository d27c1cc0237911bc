"""The run-up reference of spin_controller and the HIL measures of abb_ros.testing.assertions:
pure functions, checked on made-up bands and signals (no ROS)."""

import math

import numpy as np
import pytest

from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.stability.equilibrium import balanced_equilibrium
from abb_ros.model.stability.speed_bands import Band
from abb_ros.nodes.spin_controller.run_up import RunUp, hold_speed, in_band
from abb_ros.testing.assertions import (
    assert_balls_at_phi_star,
    peak,
    phi_star_error_deg,
    settling_time,
    time_in_bands,
)

# Below 300 rad/s (the deck's translational resonance and below) and a narrow band at 600.
BANDS = (Band(0.0, 300.0, 'X', 290.0), Band(600.0, 620.0, 'alpha', 610.0))
GUARD = 30.0


def run(reference: RunUp, dt: float, steps: int) -> np.ndarray:
    return np.array([reference.step(dt) for _ in range(steps)])


def test_reference_from_rest_jumps_over_the_low_band_then_ramps_at_the_acceleration():
    ref = RunUp(BANDS, hold=500.0, accel=100.0, guard=GUARD)
    out = run(ref, 0.01, 200)
    assert out[0] == 330.0  # straight to the band's edge plus the guard
    assert np.allclose(np.diff(out[:100]), 1.0)  # 100 rad/s^2 x 10 ms
    assert out[-1] == 500.0 and ref.holding


def test_reference_never_lies_inside_a_band_on_the_way_up_or_down():
    ref = RunUp(BANDS, hold=800.0, accel=1000.0, guard=GUARD)
    up = run(ref, 0.001, 2000)
    assert up[-1] == 800.0
    ref.hold = 450.0
    down = run(ref, 0.001, 2000)
    assert down[-1] == 450.0
    assert not any(in_band(BANDS, w) for w in np.concatenate([up, down]))
    # The narrow band is jumped over: a step from below 570 to 650, and back.
    assert np.max(np.diff(up)) == pytest.approx(650.0 - 570.0, abs=1.0)
    assert np.min(np.diff(down)) == pytest.approx(570.0 - 650.0, abs=1.0)


def test_a_target_inside_or_near_a_band_is_held_at_the_nearest_balanced_speed():
    assert hold_speed(BANDS, 500.0, 1500.0, GUARD) == 500.0
    assert hold_speed(BANDS, 612.0, 1500.0, GUARD) == 650.0
    assert hold_speed(BANDS, 590.0, 1500.0, GUARD) == 570.0
    assert hold_speed(BANDS, 100.0, 1500.0, GUARD) == 330.0
    with pytest.raises(ValueError, match='no balanced speed'):
        hold_speed((Band(0.0, 1500.0, 'X', 300.0),), 500.0, 1500.0, GUARD)


def test_settling_time_is_the_start_of_the_last_stretch_inside_the_tolerance():
    t = np.arange(10) * 0.1
    x = np.array([5, 3, 0.5, 2, 0.5, 0.2, 0.1, 0.0, 0.0, 0.0])
    assert settling_time(t, x, 0.0, 1.0) == pytest.approx(0.4)
    assert settling_time(t, x, 0.0, 10.0) == 0.0
    assert settling_time(t, np.append(x[:-1], 2.0), 0.0, 1.0) == math.inf


def test_peak_and_time_in_bands_measure_the_window_and_the_samples_inside():
    t = np.arange(6) * 0.5
    omega = np.array([0.0, 100.0, 301.0, 605.0, 700.0, 700.0])
    assert time_in_bands(t, omega, BANDS) == pytest.approx(1.5)  # at 0, 100 and 605 rad/s
    assert time_in_bands(t, omega, BANDS[:1]) == pytest.approx(1.0)
    assert time_in_bands(t, omega, BANDS[1:]) == pytest.approx(0.5)
    assert peak(t, omega, 0.4, 1.6) == 605.0


def test_ball_error_to_phi_star_matches_either_ball_to_either_place():
    drive = DriveParams(c=0.66, m=0.03 * 0.026)  # P3's metal washers: phi* = +-106.1 deg
    star = balanced_equilibrium(drive).phi_star
    assert phi_star_error_deg(star[::-1], drive) == pytest.approx(0.0, abs=1e-9)
    off = star + np.radians([0.5, -0.7]) + 2 * np.pi  # wrapped as well
    assert phi_star_error_deg(off, drive) == pytest.approx(0.7)
    assert assert_balls_at_phi_star(off, drive, 1.0) == pytest.approx(0.7)
    with pytest.raises(AssertionError, match='deg from phi'):
        assert_balls_at_phi_star(star + np.radians([2.0, 0.0]), drive, 1.0)

"""The FG speed sensor: quantised pulse periods, edge jitter, hold, timeout, determinism."""

import math

import numpy as np
import pytest

from abb_ros.model.speed_sensor import SpeedSensor, SpeedSensorConfig, fg_speed

PUBLISH_DT = 1e-3


def run(sensor, omega, duration, alpha=0.0, theta0=0.0):
    """Readings at each 1 kHz sample of theta = theta0 + omega t + alpha t^2 / 2."""
    out = []
    for i in range(int(round(duration / PUBLISH_DT)) + 1):
        t = i * PUBLISH_DT
        out.append(sensor.update(t, theta0 + omega * t + 0.5 * alpha * t * t,
                                 omega + alpha * t))
    return np.array(out)


def test_readings_are_quantised_to_whole_timer_ticks_of_the_pulse_period():
    config = SpeedSensorConfig(pulses_per_rev=6, timer_hz=1e6, edge_jitter=0.0)
    readings = run(SpeedSensor(config), omega=500.0, duration=0.2)
    held = readings[readings > 0]
    ticks = 2 * math.pi * config.timer_hz / (config.pulses_per_rev * held)
    assert np.allclose(ticks, np.round(ticks), atol=1e-6)
    # the true period is 2 pi / (6 * 500) s = 2094.395 ticks: readings of 2094 or 2095 ticks
    assert set(np.round(ticks).astype(int)) <= {2094, 2095}


def test_without_jitter_the_reading_is_within_one_tick_of_the_true_speed():
    config = SpeedSensorConfig(pulses_per_rev=12, timer_hz=1e6, edge_jitter=0.0)
    omega = 811.2
    held = run(SpeedSensor(config), omega, 0.3)[10:]
    tick_step = omega ** 2 * config.pulses_per_rev / (2 * math.pi * config.timer_hz)
    assert np.all(np.abs(held - omega) <= tick_step * 1.01)


def test_edge_jitter_spreads_the_readings_by_the_period_error():
    jitter = 5e-6
    config = SpeedSensorConfig(pulses_per_rev=6, timer_hz=1e7, edge_jitter=jitter)
    omega = 500.0
    held = run(SpeedSensor(config, seed=3), omega, 2.0)[20:]
    period = 2 * math.pi / (6 * omega)
    # the period is the difference of two jittered edges: std sqrt(2) jitter
    expected = omega * math.sqrt(2) * jitter / period
    assert np.std(held) == pytest.approx(expected, rel=0.2)
    assert np.mean(held) == pytest.approx(omega, rel=1e-3)


def test_the_reading_holds_between_pulses_and_updates_at_each_pulse():
    config = SpeedSensorConfig(pulses_per_rev=6, timer_hz=1e6, edge_jitter=0.0)
    sensor = SpeedSensor(config)
    omega = 50.0          # a pulse every 20.9 ms: about 21 samples per pulse
    readings = run(sensor, omega, 0.5, alpha=40.0)
    changes = np.count_nonzero(np.diff(readings))
    assert changes <= sensor.edges
    assert sensor.edges == math.floor((50.0 * 0.5 + 20 * 0.25) / (2 * math.pi / 6))
    assert changes > 0.8 * sensor.edges


def test_the_reading_follows_an_acceleration_with_a_pulse_period_of_delay():
    config = SpeedSensorConfig(pulses_per_rev=6, timer_hz=1e6, edge_jitter=0.0)
    alpha = 2000.0
    readings = run(SpeedSensor(config), 100.0, 0.2, alpha=alpha)
    t = np.arange(readings.size) * PUBLISH_DT
    true = 100.0 + alpha * t
    ok = readings > 0
    lag = true[ok] - readings[ok]
    period = 2 * math.pi / (6 * true[ok])
    # the reading is the mean speed over the last period, held up to one period: lag < 2 P a
    assert np.all(lag > 0) and np.all(lag < 2 * period * alpha + 1.0)


def test_no_pulse_for_the_timeout_reads_zero_and_before_two_edges_reads_zero():
    config = SpeedSensorConfig(pulses_per_rev=6, timeout=0.05)
    sensor = SpeedSensor(config)
    assert sensor.update(0.0, 0.0, 300.0) == 0.0
    moving = run(sensor, 300.0, 0.1)
    assert moving[-1] > 0
    theta = 300.0 * 0.1
    stopped = [sensor.update(0.1 + i * PUBLISH_DT, theta, 0.0) for i in range(1, 80)]
    assert stopped[30] > 0 and stopped[-1] == 0.0


def test_same_seed_same_readings_and_reset_repeats_them():
    config = SpeedSensorConfig(edge_jitter=2e-6)
    a = run(SpeedSensor(config, seed=7), 400.0, 0.2)
    sensor = SpeedSensor(config, seed=7)
    b = run(sensor, 400.0, 0.2)
    sensor.reset()
    c = run(sensor, 400.0, 0.2)
    d = run(SpeedSensor(config, seed=8), 400.0, 0.2)
    assert np.array_equal(a, b) and np.array_equal(a, c)
    assert not np.array_equal(a, d)


def test_a_re_expressed_theta_produces_no_edge():
    config = SpeedSensorConfig(edge_jitter=0.0)
    sensor = SpeedSensor(config)
    run(sensor, 300.0, 0.05)
    edges = sensor.edges
    value = sensor.value
    sensor.shift_angle(2.0)
    t = 0.05 + 1e-6
    sensor.update(t, 300.0 * t + 2.0, 300.0)
    assert sensor.edges == edges and sensor.value == value


def test_fg_speed_is_two_pi_over_pulses_times_period():
    config = SpeedSensorConfig(pulses_per_rev=12, timer_hz=2e6)
    assert fg_speed(1000, config) == pytest.approx(2 * math.pi / (12 * 1000 / 2e6))


def test_the_compiled_fg_edge_capture_equals_its_python_twin_bit_for_bit():
    """What ABB_ROS_NO_JIT runs (the kernel's Python source) is what the node runs: a run
    forwards then backwards through many edges."""
    from abb_ros.model import speed_sensor as fg
    normals = np.random.default_rng(2).standard_normal(1000)
    states = []
    for kern in (fg.JIT, fg.PY):
        state = np.zeros(fg.N_STATE)
        samples = [(i * 1e-3, 30.0 * math.sin(i * 0.02), 0.0) for i in range(300)]
        used = 0
        for a, b in zip(samples, samples[1:]):
            k = abs(math.floor(b[1] / (math.pi / 3)) - math.floor(a[1] / (math.pi / 3)))
            kern.fg_edges(a, b, math.pi / 3, 1e6, 6, 1e-6, normals[used:used + k], state)
            used += k
        states.append(state)
    assert states[0].tobytes() == states[1].tobytes() and states[0][fg.EDGES] > 100

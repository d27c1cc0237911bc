"""The FG speed sensor: quantised pulse periods, edge jitter, hold, timeout, determinism."""

import math

import numpy as np
import pytest

from abb_ros.model.sensors.speed_sensor import SpeedSensor, SpeedSensorConfig, fg_speed

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
    # ~950 pulse periods, neighbours sharing an edge: their std scatters by about 3 % from
    # seed to seed (seeds 3-12 measured: -4.2 % to +4.9 %); 10 % is twice the widest
    assert np.std(held) == pytest.approx(expected, rel=0.1)
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
    from abb_ros.model.sensors import speed_sensor as fg
    normals = np.random.default_rng(2).standard_normal(1000)
    states = []
    for kern in (fg.JIT, fg.PY):
        state = np.zeros(fg.N_STATE)
        samples = [(i * 1e-3, 30.0 * math.sin(i * 0.02), 0.0) for i in range(300)]
        used = 0
        for a, b in zip(samples, samples[1:]):
            k = abs(math.floor(b[1] / (math.pi / 3)) - math.floor(a[1] / (math.pi / 3)))
            kern.fg_edges(a, b, math.pi / 3, np.zeros(0), 1e6, 6, 1e-6, normals[used:used + k],
                          state)
            used += k
        states.append(state)
    assert states[0].tobytes() == states[1].tobytes() and states[0][fg.EDGES] > 100


# ---- pitch error: the once-per-revolution pattern of the magnet poles -----------------------

def edge_readings(sensor, omega, duration):
    """(edge index k, reading) at each sample where a new edge was captured, at a steady
    omega from theta = 0."""
    from abb_ros.model.sensors import speed_sensor as fg
    out, edges = [], sensor.edges
    offsets, pitch = sensor.pitch_offsets, sensor.config.pitch
    for i in range(int(round(duration / PUBLISH_DT)) + 1):
        t = i * PUBLISH_DT
        value = sensor.update(t, omega * t, omega)
        if sensor.edges != edges and value > 0:
            out.append((fg.PY._edge_index(omega * t, pitch, offsets), value))
        edges = sensor.edges
    return out


def interval_theory(omega, offsets, k):
    """The reading of the interval ending at edge k: omega pitch / (pitch + d_k - d_{k-1})."""
    n = offsets.size
    pitch = 2 * math.pi / n
    return omega * pitch / (pitch + offsets[k % n] - offsets[(k - 1) % n])


def test_the_pitch_pattern_has_zero_mean_the_rms_asked_for_and_comes_from_the_seed():
    config = SpeedSensorConfig(pulses_per_rev=12, pitch_error=0.004)
    d = SpeedSensor(config, seed=5).pitch_offsets
    assert d.size == 12 and abs(d.mean()) < 1e-17
    assert math.sqrt(np.mean(d * d)) == pytest.approx(0.004, rel=1e-12)
    assert np.array_equal(d, SpeedSensor(config, seed=5).pitch_offsets)
    assert not np.array_equal(d, SpeedSensor(config, seed=6).pitch_offsets)
    assert SpeedSensor(SpeedSensorConfig(pulses_per_rev=1, pitch_error=0.1)).pitch_offsets.size \
        == 0                                    # one edge a revolution: no pitch to be wrong
    assert SpeedSensor(SpeedSensorConfig()).pitch_offsets.size == 0
    with pytest.raises(ValueError, match='pitch_error'):
        SpeedSensorConfig(pulses_per_rev=6, pitch_error=math.pi / 6 ** 1.5)


def test_the_node_parameter_refuses_a_pitch_error_that_would_reorder_the_edges():
    from abb_ros.model.parameters.params import ParamError
    from abb_ros.nodes.ros.parameter_table import specs_for
    from abb_ros.nodes.simulator.hil_settings import hil_settings
    values = {name: spec.default for name, spec in specs_for('simulator').items()}
    assert hil_settings(values).speed_sensor == SpeedSensorConfig()
    values['speed_sensor.pitch_error'] = 0.2
    assert hil_settings(values).speed_sensor.pitch_error == 0.2
    values['speed_sensor.pulses_per_rev'] = 12
    with pytest.raises(ParamError, match=r"'speed_sensor.pitch_error'.*0\.0755"):
        hil_settings(values)


def test_each_edge_interval_reads_omega_pitch_over_pitch_plus_its_pitch_error_difference():
    for pulses, seed, pitch_error in ((6, 0, 0.01), (12, 3, 0.005), (6, 9, 0.05)):
        config = SpeedSensorConfig(pulses_per_rev=pulses, edge_jitter=0.0,
                                   pitch_error=pitch_error)
        sensor = SpeedSensor(config, seed=seed)
        omega = 300.0
        got = edge_readings(sensor, omega, 0.3)
        assert len(got) > 10 * pulses
        d = sensor.pitch_offsets
        for k, value in got:
            expected = interval_theory(omega, d, k)
            ticks = 2 * math.pi * config.timer_hz / (pulses * expected)
            assert abs(value - expected) <= expected / (ticks - 1), (pulses, k)
        # the pattern is visible (several ticks), and it repeats every revolution
        spread = max(v for _, v in got) - min(v for _, v in got)
        assert spread > 0.9 * omega * (np.ptp(d - np.roll(d, 1)) / config.pitch)


def test_a_pitch_error_shows_at_the_rotation_frequency_with_the_theoretical_amplitude():
    """At 10 rev/s over 20 whole revolutions of 1 kHz readings, the spectrum has lines at
    10 Hz and its multiples only, and the 10 Hz line is that of the held readings
    omega pitch / (pitch + d_k - d_{k-1}) sampled at the same instants."""
    omega, revs = 2 * math.pi * 10.0, 20
    amplitudes = {}
    for pitch_error in (0.0, 0.01):
        config = SpeedSensorConfig(pulses_per_rev=6, edge_jitter=0.0, pitch_error=pitch_error)
        sensor = SpeedSensor(config, seed=4)
        readings = run(sensor, omega, 0.1 + revs * 0.1)[100:100 + revs * 100]
        spectrum = 2 * np.abs(np.fft.rfft(readings)) / readings.size
        amplitudes[pitch_error] = spectrum[revs]
        if pitch_error:
            d, pitch = sensor.pitch_offsets, config.pitch
            t = np.arange(100, 100 + revs * 100) * PUBLISH_DT
            k = np.floor((omega * t) / pitch).astype(int)     # the last edge at or before t
            k -= (k * pitch + d[k % 6] > omega * t)
            theory = interval_theory(omega, d, k)
            expected = 2 * np.abs(np.fft.rfft(theory)[revs]) / theory.size
            off_lines = np.delete(spectrum[1:], np.arange(revs - 1, spectrum.size - 1, revs))
    assert amplitudes[0.01] == pytest.approx(expected, rel=0.01)
    assert 0.005 * omega < amplitudes[0.01] < 0.02 * omega       # ~1 % of pitch: ~1 % of omega
    assert off_lines.max() < 1e-9 * omega                          # once per revolution only
    assert amplitudes[0.0] < 2e-3                                   # quantisation only


def test_over_a_revolution_the_mean_speed_is_exact_and_the_readings_average_as_theory():
    config = SpeedSensorConfig(pulses_per_rev=6, edge_jitter=0.0, pitch_error=0.02)
    sensor = SpeedSensor(config, seed=1)
    omega = 250.0
    got = edge_readings(sensor, omega, 0.5)
    d = sensor.pitch_offsets
    for start in range(0, len(got) - 6, 6):
        revolution = [value for _, value in got[start:start + 6]]
        # the six periods add up to the revolution time (to one tick of the timer)
        revolution_time = sum(config.pitch / v for v in revolution)
        assert revolution_time == pytest.approx(2 * math.pi / omega, abs=1.01 / config.timer_hz)
        # their arithmetic mean exceeds omega by the second order of the pitch error
        mean = np.mean([interval_theory(omega, d, k) for k, _ in got[start:start + 6]])
        assert np.mean(revolution) == pytest.approx(mean, rel=1e-4)
        assert np.mean(revolution) > omega


def test_a_zero_pitch_error_gives_the_readings_of_the_sensor_without_one():
    """Reference: sha256 of these readings made with speed_sensor.py before the pitch error
    existed (run-up, reversals, 6, 12 and 1 pulses)."""
    import hashlib
    digest = hashlib.sha256()
    for pulses, seed, pitch_error in ((6, 0, 0.0), (12, 5, 0.0), (1, 3, 0.1)):
        sensor = SpeedSensor(SpeedSensorConfig(pulses_per_rev=pulses, pitch_error=pitch_error),
                             seed=seed)
        readings = np.array([
            sensor.update(t, 60.0 * math.sin(3.0 * t) + 20.0 * t * t,
                          180.0 * math.cos(3.0 * t) + 40.0 * t)
            for t in (i * 1e-3 for i in range(3001))])
        digest.update(readings.tobytes())
    assert digest.hexdigest() == \
        '67056bb6f2d6bd02c2216de493b122e5d0a88a7dc125651027e8a5924270006f'


def test_the_compiled_fg_with_a_pitch_error_equals_its_python_twin_bit_for_bit():
    from abb_ros.model.sensors import speed_sensor as fg
    offsets = fg.pitch_pattern(SpeedSensorConfig(pitch_error=0.1), seed=2)
    normals = np.random.default_rng(2).standard_normal(1000)
    states, counts = [], []
    for kern in (fg.JIT, fg.PY):
        state = np.zeros(fg.N_STATE)
        samples = [(i * 1e-3, 30.0 * math.sin(i * 0.02) - 3.0, 0.0) for i in range(300)]
        used = 0
        for a, b in zip(samples, samples[1:]):
            k = abs(fg.PY._edge_index(b[1], math.pi / 3, offsets)
                    - fg.PY._edge_index(a[1], math.pi / 3, offsets))
            assert k == abs(kern._edge_index(b[1], math.pi / 3, offsets)
                            - kern._edge_index(a[1], math.pi / 3, offsets))
            kern.fg_edges(a, b, math.pi / 3, offsets, 1e6, 6, 1e-6, normals[used:used + k],
                          state)
            used += k
        states.append(state)
        counts.append(used)
    assert states[0].tobytes() == states[1].tobytes() and counts[0] == counts[1] > 100


# ---- low speed: no edge within the timeout --------------------------------------------------

def test_below_two_pi_over_pulses_times_timeout_the_reading_drops_to_zero_between_edges():
    config = SpeedSensorConfig(pulses_per_rev=6, timeout=0.1)
    low = 2 * math.pi / (6 * 0.1)
    assert SpeedSensor(config).min_speed == pytest.approx(low, rel=1e-15)   # 10.47 rad/s
    assert SpeedSensor(SpeedSensorConfig(pulses_per_rev=12, timeout=0.05)).min_speed == \
        pytest.approx(2 * math.pi / (12 * 0.05))
    above = SpeedSensor(config)
    readings = run(above, 1.03 * low, 3.0)
    first = np.argmax(readings > 0)
    assert 0 < first < 250 and np.all(readings[first:] > 0)
    assert above.state(1.03 * low) == 'measuring'
    below = SpeedSensor(config)
    readings = run(below, 0.97 * low, 3.0)
    read = readings > 0
    # each interval shows for the timeout after its edge, then 0 until the next edge
    assert 0.3 < read.mean() < 0.99 and np.count_nonzero(np.diff(read.astype(int)) == 1) > 20
    assert readings[read] == pytest.approx(0.97 * low, rel=1e-3)
    assert below.state(0.97 * low) == 'below_min_speed'
    assert below.state(0.0) == 'stopped' and below.state(0.009 * low) == 'stopped'
    assert SpeedSensor(config).state(300.0) == 'waiting_for_edges'    # no two edges yet


def test_a_pitch_error_raises_the_minimum_speed_to_that_of_the_widest_edge_interval():
    config = SpeedSensorConfig(pulses_per_rev=6, edge_jitter=0.0, timeout=1.0,
                               pitch_error=0.1)
    sensor = SpeedSensor(config)
    d = sensor.pitch_offsets
    widest = config.pitch + np.max(d - np.roll(d, 1))
    assert sensor.min_speed == pytest.approx(widest / 1.0, rel=1e-15)
    assert sensor.min_speed > 1.1 * 2 * math.pi / (6 * 1.0)
    # between the widest interval's speed and the next widest one's (17 ms either side of
    # the timeout): the reading drops to 0 once per revolution
    second = config.pitch + np.sort(d - np.roll(d, 1))[-2]
    omega = 0.5 * (second + widest) / 1.0
    readings = run(sensor, omega, 10 * 2 * math.pi / omega)
    drops = np.count_nonzero(np.diff((readings > 0).astype(int)) == -1)
    assert drops in (9, 10)
    assert sensor.state(omega) == 'below_min_speed'


@pytest.mark.ros
@pytest.mark.slow
def test_the_simulator_node_states_the_fg_below_its_minimum_speed_on_diagnostics():
    """A real simulator node over rclpy/DDS: turning at 2 rad/s (an edge every 0.5 s, timeout
    0.1 s) the simulation status says so (WARN while spindle/speed reads 0), at 300 rad/s it
    measures, at rest it is stopped."""
    from diagnostic_msgs.msg import DiagnosticStatus
    from std_msgs.msg import Float64
    from test_simulator_node import Plant
    plant = Plant(real_time_factor=0.0, publish_rate_hz=100, seed=0,
                  **{'spindle.initial_speed': 2.0, 'speed_sensor.pitch_error': 0.02})
    try:
        expected = SpeedSensor(SpeedSensorConfig(pitch_error=0.02), seed=0).min_speed
        assert expected > 2 * math.pi / (6 * 0.1)

        def state(name, level=None):
            status = plant.status()
            return (status is not None and plant.values().get('fg_state') == name
                    and (level is None or status.level == level))

        plant.wait(lambda: state('below_min_speed', DiagnosticStatus.WARN), 'below_min_speed')
        assert float(plant.values()['fg_min_speed']) == pytest.approx(expected, rel=1e-12)
        assert (f'spindle/speed reads 0: the spindle turns below the FG minimum '
                f'{expected:.3f} rad/s') in plant.status().message
        pub = plant.command(300.0)
        plant.wait(lambda: state('measuring'), 'measuring at 300 rad/s')
        assert 'reads 0' not in plant.status().message
        pub.publish(Float64(data=0.0))
        plant.wait(lambda: state('stopped'), 'stopped')
        assert 'reads 0' not in plant.status().message
    finally:
        plant.close()

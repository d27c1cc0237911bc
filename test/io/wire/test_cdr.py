"""abb_ros.io.wire.cdr encodes exactly what rclpy messages with the same contents serialise to.

The messages are filled field by field from ros_messages' contents (rclpy_messages); the
reference encoder is cdr_reference.cdr_bytes (rosbags' CDR), which test_bag checks against
the bytes a raw subscription receives over Fast DDS. Equality is exact (byte for byte): both
encode the same float objects, so there is no tolerance.
"""

import dataclasses
import string
import struct

import numpy as np
import pytest
import rclpy_messages
from cdr_reference import cdr_bytes
from diagnostic_msgs.msg import DiagnosticStatus

from abb_ros.io.wire import cdr, ros_messages
from abb_ros.model.dynamics.state import n_coords
from abb_ros.model.sensors import imu as deck_imu
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuConfig, ImuReading
from abb_ros.model.sensors.sampling import Outputs, Sample

SAMPLES = 300


def _awkward_floats(rng, size):
    """Normal values over many decades, with signed zeros, subnormals and extremes mixed in
    (finite: the simulator publishes nothing non-finite)."""
    x = rng.standard_normal(size) * 10.0 ** rng.integers(-300, 300, size)
    specials = np.array([0.0, -0.0, 5e-324, -1.7976931348623157e308, 1e308])
    pick = rng.random(size) < 0.1
    x[pick] = rng.choice(specials, pick.sum())
    return x


def _random_sample(rng):
    n = int(rng.integers(0, 13))
    y = _awkward_floats(rng, 2 * n_coords(n)) if rng.random() < 0.9 else None
    imu = None
    if y is None or rng.random() < 0.5:
        imu = ImuReading(_awkward_floats(rng, 3), _awkward_floats(rng, 3))
    speed = float(_awkward_floats(rng, 1)[0]) if y is not None and rng.random() < 0.5 else None
    effort = float(_awkward_floats(rng, 1)[0]) if y is not None and rng.random() < 0.5 else None
    return Sample(int(rng.integers(0, 2**36)), n, y, imu, effort=effort, speed=speed)


def _random_imu_config(rng):
    return ImuConfig(rate=float(rng.integers(1, 20000)),
                     accel_noise_density=float(rng.random() * 10.0 ** rng.integers(-6, 2)),
                     gyro_noise_density=float(rng.random() * 10.0 ** rng.integers(-6, 2)))


def _encodes_as_rclpy(rng, sample) -> list[str]:
    """Encode ``sample`` with a random IMU configuration, time base and /clock choice, check
    every message against its rclpy message serialised; return the topics."""
    config = TYPICAL_IMU if rng.random() < 0.3 else _random_imu_config(rng)
    dt_ns = int(rng.integers(1, 10**6))
    epoch_ns = int(rng.integers(0, 2**60)) if rng.random() < 0.5 else 0
    with_clock = bool(rng.random() < 0.5)
    stamp_ns, encoded = cdr.sample_cdr(sample, dt_ns, config, epoch_ns, with_clock)
    messages = rclpy_messages.sample_messages(sample, dt_ns, config, epoch_ns, with_clock)
    assert stamp_ns == sample.stamp_ns(dt_ns, epoch_ns)
    assert [t for t, _ in encoded] == [t for t, _ in messages]
    for (topic, data), (_, msg) in zip(encoded, messages):
        assert data == cdr_bytes(msg), (topic, sample)
    return [t for t, _ in encoded]


def test_every_topic_of_a_sample_encodes_to_the_bytes_of_its_serialised_rclpy_message():
    rng = np.random.default_rng(20050547)
    seen = set()
    for _ in range(SAMPLES):
        seen.update(_encodes_as_rclpy(rng, _random_sample(rng)))
    assert seen == {'joint_states', 'deck/pose', 'deck/twist', 'deck/imu', '/clock',
                    'spindle/speed'}


def _with_outputs(sample):
    """The sample as a fused period gives it: y, the IMU reading, the deck's pose and the
    effort in one vector (Sample.outputs), y and the reading views of it."""
    at = Outputs.of(sample.n)
    out = np.empty(at.size)
    out[:at.state] = sample.y
    out[at.imu:at.imu + 3], out[at.imu + 3:at.deck] = sample.imu.accel, sample.imu.gyro
    deck_imu.JIT.deck_pose_twist(sample.y, sample.n, out[at.deck:at.effort])
    out[at.effort] = 0.0 if sample.effort is None else sample.effort
    out[at.zero] = 0.0
    return dataclasses.replace(sample, y=out[:at.state], outputs=out,
                               imu=ImuReading(out[at.imu:at.imu + 3], out[at.imu + 3:at.deck]))


def test_a_sample_with_its_outputs_in_one_vector_encodes_to_the_bytes_of_its_rclpy_message():
    """The compiled fill of one byte template (cdr.Frame) against rclpy's serialisation."""
    rng = np.random.default_rng(20051102)
    filled = 0
    while filled < SAMPLES:
        sample = _random_sample(rng)
        if sample.y is None or sample.imu is None:
            continue
        _encodes_as_rclpy(rng, _with_outputs(sample))
        filled += 1


def test_a_stamp_past_the_range_of_time_is_refused_with_or_without_the_outputs_vector():
    """builtin_interfaces/Time holds int32 seconds: 2**31 s and later cannot be encoded."""
    rng = np.random.default_rng(7)
    sample = Sample(1, 2, _awkward_floats(rng, 2 * n_coords(2)),
                    ImuReading(_awkward_floats(rng, 3), _awkward_floats(rng, 3)))
    for each in (sample, _with_outputs(sample)):
        with pytest.raises(struct.error):
            cdr.sample_cdr(each, 1, TYPICAL_IMU, 2**31 * 10**9)
        assert cdr.sample_cdr(each, 1, TYPICAL_IMU, 2**31 * 10**9 - 2)[0] == 2**31 * 10**9 - 1


def _random_text(rng, alphabet):
    return ''.join(rng.choice(list(alphabet), int(rng.integers(0, 12))))


@pytest.mark.parametrize('alphabet', [string.ascii_letters + ' :._', 'aé°ω✓𝜑'])
def test_diagnostics_encode_to_the_bytes_of_the_serialised_diagnostic_array(alphabet):
    # Strings of every length (and multi-byte UTF-8) move the alignment of what follows.
    rng = np.random.default_rng(len(alphabet))
    levels = [DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR,
              DiagnosticStatus.STALE]
    for _ in range(100):
        values = {_random_text(rng, alphabet): v for v in (
            float(_awkward_floats(rng, 1)[0]), int(rng.integers(-10**9, 10**9)),
            bool(rng.random() < 0.5), _random_text(rng, alphabet))}
        args = (_random_text(rng, alphabet), levels[int(rng.integers(0, 4))],
                _random_text(rng, alphabet), values)
        stamp_ns = int(rng.integers(0, 2**60))
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        data = cdr.diagnostic_array(sec, nanosec, ros_messages.diagnostics_content(*args))
        assert data == cdr_bytes(rclpy_messages.diagnostics(stamp_ns, *args))
        assert cdr.diagnostics(stamp_ns, *args) == data


def test_layout_aligns_each_primitive_to_its_size_after_the_encapsulation_header():
    # 'ab' + NUL ends at payload offset 7, so the double starts at 8 (byte 12 of the buffer).
    st, consts = cdr.Layout().string('ab').var('d').compile()
    data = st.pack(*consts, 1.5)
    assert data[:4] == cdr.ENCAPSULATION
    assert data[4:] == b'\x03\x00\x00\x00ab\x00\x00' + np.float64(1.5).tobytes()
    # An empty sequence of doubles is not aligned for its (absent) elements.
    assert cdr.Layout().const('B', 1).sequence('d', 0).constant_bytes()[4:] == \
        b'\x01\x00\x00\x00' + b'\x00\x00\x00\x00'


@pytest.mark.parametrize('n', [0, 1, 3, 12])
def test_a_batch_encodes_to_the_bytes_of_its_samples_one_by_one(n):
    from abb_ros.model.sensors.sampling import SampleBatch
    rng = np.random.default_rng(n)
    rows = 40
    batch = SampleBatch(list(range(7, 7 + 10 * rows, 10)), n,
                        _awkward_floats(rng, (rows, 2 * n_coords(n))),
                        _awkward_floats(rng, (rows, 6)), _awkward_floats(rng, rows).tolist())
    config = ImuConfig(accel_noise_density=3e-3, gyro_noise_density=1e-4)
    for with_clock in (False, True):
        expected = [cdr.sample_cdr(s, 100_000, config, 12_345, with_clock)
                    for s in batch.samples()]
        assert cdr.batch_cdr(batch, 100_000, config, 12_345, with_clock) == expected


def test_a_samplers_batch_holds_the_samples_of_its_periods_one_by_one():
    from abb_ros.model.dynamics.integrate import Simulation
    from abb_ros.model.parameters.params import DriveParams
    from abb_ros.model.sensors.imu import ImuModel
    from abb_ros.model.sensors.sampling import PlantSampler
    from abb_ros.model.sensors.speed_sensor import SpeedSensor

    def sampler():
        sim = Simulation(DriveParams(n=2), 300.0, 1e-4)
        return PlantSampler(sim, ImuModel(TYPICAL_IMU, 3), 10, 10, speed=SpeedSensor(seed=3))

    one, many = sampler(), sampler()
    assert many.batches()
    expected = [cdr.sample_cdr(s, 100_000, TYPICAL_IMU, with_clock=True)
                for _ in range(300) for s in one.next_period()]
    got = cdr.batch_cdr(many.next_periods(120), 100_000, TYPICAL_IMU, with_clock=True)
    got += cdr.batch_cdr(many.next_periods(180), 100_000, TYPICAL_IMU, with_clock=True)
    assert got == expected
    assert many.sim.steps == one.sim.steps and np.array_equal(many.sim.y, one.sim.y)

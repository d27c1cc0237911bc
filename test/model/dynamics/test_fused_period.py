"""A publish period integrated and read in two compiled calls gives the step-by-step samples.

``PlantSampler.next_period`` (the live node and ``abb-sim run``), where the IMU is read at
every state sample, advances a period and computes q'' in one call
(``Simulation.advance_accelerations``), then the IMU reading and the deck's pose in another,
into one outputs vector. The reference here steps the same drive with ``Simulation.advance``
and reads with ``PlantSampler.sample_now`` (``accelerations`` and ``ImuModel.read``).
Tolerance: none. The same operations run in the same order on the same numbers, so every
state, reading and message must be equal bit for bit, whatever the drive, the mode or the
faults switched on and off on the way.
"""

import numpy as np
import pytest

from abb_ros.io.wire import cdr
from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.integrate import Simulation, StateError
from abb_ros.model.dynamics.spindle import TorqueMotor
from abb_ros.model.dynamics.state import DECK
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.sensors.faults import ImuFaults, SpeedFaults
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuModel
from abb_ros.model.sensors.sampling import PlantSampler
from abb_ros.model.sensors.speed_sensor import SpeedSensor

PERIODS = 600
"""Publish periods of 1 ms compared per case (0.6 s: the balls move by tens of degrees)."""

DRIVES = {
    'table 1, n = 2': lambda: (DriveParams(), None),
    'n = 10': lambda: (DriveParams(n=10), None),
    'steel balls with contact and rolling resistance':
        lambda: (DriveParams(n=4, r_ball=2.873e-3, contact_E=2e11, rolling_mu=1e-6), None),
    'torque mode': lambda: (DriveParams(), TorqueMotor()),
}


class SteppedSampler(PlantSampler):
    """The reference: a period stepped with ``Simulation.advance``, then read by ``sample_now``."""

    def next_period(self):
        self.sim.advance(self.publish_every - self.sim.steps % self.publish_every)
        sample = self.sample_now()
        return [] if sample is None else [sample]


def _sampler(drive: str, fuse: bool, imu_faults=None, speed_faults=None) -> PlantSampler:
    params, spindle = DRIVES[drive]()
    sim = Simulation(params, 2.7 * params.omega0, 1e-4, spindle=spindle)
    if spindle is not None:
        sim.set_command(0.05)
    return (PlantSampler if fuse else SteppedSampler)(
        sim, ImuModel(TYPICAL_IMU, seed=5), 10, 10, SpeedSensor(seed=5), imu_faults=imu_faults,
        speed_faults=speed_faults)


def _same(a, b) -> None:
    assert (a.steps, a.n, a.effort, a.speed) == (b.steps, b.n, b.effort, b.speed)
    np.testing.assert_array_equal(a.y, b.y)
    assert (a.imu is None) == (b.imu is None)
    if a.imu is not None:
        np.testing.assert_array_equal(a.imu.accel, b.imu.accel)
        np.testing.assert_array_equal(a.imu.gyro, b.imu.gyro)
    assert a.is_finite() and b.is_finite()
    for with_clock in (False, True):
        assert (cdr.sample_cdr(a, 100_000, TYPICAL_IMU, 7, with_clock)
                == cdr.sample_cdr(b, 100_000, TYPICAL_IMU, 7, with_clock))


@pytest.mark.parametrize('drive', sorted(DRIVES))
def test_a_fused_period_gives_the_samples_and_messages_of_the_step_by_step_one(drive):
    fused, stepped = _sampler(drive, True), _sampler(drive, False)
    for _ in range(PERIODS):
        (a,), (b,) = fused.next_period(), stepped.next_period()
        assert a.outputs is not None and b.outputs is None
        _same(a, b)
    assert fused.sim.steps == stepped.sim.steps
    np.testing.assert_array_equal(fused.sim.y, stepped.sim.y)


def test_faults_switched_on_and_off_give_the_same_samples_fused_or_not():
    """Dropout, stuck and bias steps of the IMU and the speed sensor's faults, in turn: a
    faulted reading leaves the outputs vector (the message is then encoded on its own)."""
    pairs = [(ImuFaults(), SpeedFaults(seed=5)) for _ in range(2)]
    fused = _sampler('table 1, n = 2', True, *pairs[0])
    stepped = _sampler('table 1, n = 2', False, *pairs[1])
    settings = [{}, {'dropout': True}, {'stuck': True},
                {'accel_bias_step': (0.5, 0.0, -1.0), 'gyro_bias_step': (0.0, 0.02, 0.0)}, {}]
    for setting in settings:
        for imu_faults, speed_faults in pairs:
            for name in ('dropout', 'stuck'):
                setattr(imu_faults, name, setting.get(name, False))
            imu_faults.accel_bias_step = setting.get('accel_bias_step', (0.0, 0.0, 0.0))
            imu_faults.gyro_bias_step = setting.get('gyro_bias_step', (0.0, 0.0, 0.0))
            speed_faults.dropout = bool(setting.get('dropout'))
            speed_faults.noise = 2.0 if setting.get('stuck') else 0.0
        for _ in range(40):
            (a,), (b,) = fused.next_period(), stepped.next_period()
            _same(a, b)
            assert (a.outputs is None) == bool(setting), setting


@pytest.mark.parametrize('kern', [kernels.JIT, kernels.PY], ids=['compiled', 'python'])
def test_advance_accelerations_is_advance_then_accelerations(kern):
    one, two = (Simulation(DriveParams(), 800.0, 1e-4, kern=kern) for _ in range(2))
    qdd = np.empty(one.N)
    for nsteps in (10, 1, 7):
        one.advance_accelerations(nsteps, qdd)
        two.advance(nsteps)
        np.testing.assert_array_equal(qdd, two.accelerations())
        np.testing.assert_array_equal(one.y, two.y)
        assert one.steps == two.steps


def test_a_bad_state_stops_the_fused_period_where_the_step_by_step_one_stops():
    fused, stepped = _sampler('table 1, n = 2', True), _sampler('table 1, n = 2', False)
    for sampler in (fused, stepped):
        sampler.next_period()
        sampler.sim.y[DECK] = 1.0       # the deck 1 m off centre: outside the envelope
    errors = []
    for sampler in (fused, stepped):
        with pytest.raises(StateError) as err:
            sampler.next_period()
        errors.append(str(err.value))
    assert errors[0] == errors[1]
    assert fused.sim.steps == stepped.sim.steps
    np.testing.assert_array_equal(fused.sim.y, stepped.sim.y)

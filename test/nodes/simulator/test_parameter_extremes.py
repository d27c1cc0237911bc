"""Every accepted simulator parameter keeps every published value finite.

A hostile sweep over the parameter table: each floating-point parameter (and each element of
a floating-point array) at huge, tiny, negative and boundary values, merged into the defaults
as ``ros2 param set`` and ``--params-file`` would merge it. Each value is either refused with
a ParamError naming the parameter (the set-parameters reason, exit code 2 at start-up), or
the plant built from it, as the simulator node builds it (FG speed sensor, IMU faults, speed
noise, a shock of the disturbance parameters, the fastest accepted speed command), runs with
finite readings only, or stops on the state envelope (StateError: the node's ERROR state).
The lower-rate streams (markers at ``visualization.rate_hz``, ``joint_states_throttle`` at
``joint_states_throttle_hz``) are slotted on each sample's stamp as the node slots them.
An OverflowError, an infinity or a NaN on a topic is the failure this file looks for.
"""

import math

import numpy as np
import pytest

from abb_ros.model.dynamics.integrate import Simulation, StateError
from abb_ros.model.parameters.param_spec import DOUBLE, DOUBLE_ARRAY, ParamError
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.sensors import disturbances
from abb_ros.model.sensors.faults import ImuFaults, SpeedFaults
from abb_ros.model.sensors.imu import ImuModel
from abb_ros.model.sensors.sampling import PlantSampler
from abb_ros.model.sensors.speed_sensor import SpeedSensor
from abb_ros.nodes.ros.ros_params import P3_WBAR, SIMULATOR_PARAMS, settings_from, with_ros_names
from abb_ros.runtime.rate_slots import RateSlots

HOSTILE = (1e308, 1e200, 1e20, -1e308, -1.0, 5e-324, -5e-324, 0.0)
"""Values no range should let through unless the plant stays finite with them."""
PERIODS = 40
"""Publish periods run per accepted value (40 ms at the default 1 kHz): enough for the FG,
the IMU noise and bias walk, the speed loop and the shock to reach every output."""


def _defaults() -> dict:
    values = {name: spec.default for name, spec in SIMULATOR_PARAMS.items()}
    values['spindle.initial_speed'] = P3_WBAR * DriveParams().omega0
    return values


def _cases():
    for name, spec in SIMULATOR_PARAMS.items():
        if spec.type == DOUBLE:
            for value in HOSTILE + tuple(x for x in (spec.low, spec.high) if x is not None):
                yield pytest.param(name, value, id=f'{name}={value:g}')
        elif spec.type == DOUBLE_ARRAY:
            for i in range(spec.length):
                for value in HOSTILE:
                    vector = list(spec.default)
                    vector[i] = value
                    yield pytest.param(name, vector, id=f'{name}[{i}]={value:g}')
            for value in HOSTILE[:4]:
                yield pytest.param(name, [value] * spec.length, id=f'{name}[:]={value:g}')


def _run_plant(drive, s, throttle_hz: float) -> list:
    """Run the plant of (drive, settings) as the node wires it; return every reading."""
    sim = Simulation(drive, s.initial_speed, s.dt_ns * 1e-9, spindle=s.spindle())
    imu = ImuModel(s.imu, seed=s.seed)
    faults = ImuFaults(accel_bias_step=s.hil.imu_accel_bias_step,
                       gyro_bias_step=s.hil.imu_gyro_bias_step)
    speed_faults = SpeedFaults(noise=s.hil.speed_noise, seed=s.seed)
    sampler = PlantSampler(sim, imu, s.publish_every, s.imu_every,
                           SpeedSensor(s.hil.speed_sensor, s.seed), faults, speed_faults)
    sim.set_speed_command(s.max_spindle_speed)
    if s.spindle_mode == 'torque':
        sim.set_command(s.motor.I_max)
    readings = []
    markers, throttle = RateSlots(), RateSlots()
    for period in range(PERIODS):
        if period == PERIODS // 2:
            sim.y[:] = disturbances.apply_shock(sim.y, drive.n, s.hil.shock_velocity)
        for sample in sampler.next_period():
            assert sample.is_finite()
            stamp_ns = sample.stamp_ns(s.dt_ns, 0)
            markers.opens(stamp_ns, s.hil.visualization_rate_hz)
            throttle.opens(stamp_ns, throttle_hz)
            readings.extend(x for x in (sample.speed, sample.effort) if x is not None)
            if sample.imu is not None:
                readings.extend(sample.imu.accel.tolist() + sample.imu.gyro.tolist())
    return readings


@pytest.mark.parametrize('name, value', list(_cases()))
def test_an_accepted_value_keeps_every_published_value_finite(name, value):
    """Refused with a reason naming the parameter, or the plant's outputs stay finite."""
    values = _defaults()
    values[name] = value
    if name.startswith('motor.'):
        values['spindle.mode'] = 'torque'    # the motor drives the spindle in torque mode only
    try:
        drive, settings = with_ros_names(settings_from)(values)   # as validate_change
    except ParamError as err:     # this parameter, or one it must agree with, is named
        assert err.name in SIMULATOR_PARAMS and 'valid range is' in str(err), err
        return
    try:
        readings = _run_plant(drive, settings, values['joint_states_throttle_hz'])
    except StateError:
        return     # the envelope stops the plant: the node reports ERROR, publishes nothing
    assert all(math.isfinite(x) for x in readings)
    assert np.isfinite(readings).all()


def test_every_floating_point_range_of_every_node_is_bounded():
    """No float parameter of any node reaches infinity: each range is derived and finite.

    The other nodes' floats (the controller's target speed and acceleration, the recorder's
    discovery period) feed timers and commands, where 1e308 overflows as it did in the plant.
    """
    from abb_ros.nodes.ros.parameter_table import SPECS
    unbounded = [s.name for s in SPECS if s.type in (DOUBLE, DOUBLE_ARRAY) and not (
        s.low is not None and s.high is not None and math.isfinite(s.low - s.high))]
    assert unbounded == []


@pytest.mark.parametrize('name, value', [('imu.accel_noise_density', 1e200),
                                         ('imu.gyro_noise_density', 1e200),
                                         ('fault.imu_accel_bias_step', [1e308] * 3),
                                         ('fault.speed_noise', 1e308)])
def test_the_values_that_killed_the_plant_are_refused_with_the_full_scale(name, value):
    """The reported cases: refused, the reason naming the parameter and its finite range."""
    values = _defaults()
    values[name] = value
    with pytest.raises(ParamError, match=f"'{name}'.*valid range is .*[0-9]"):
        settings_from(values)

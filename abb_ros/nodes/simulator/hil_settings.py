"""The simulator's HIL I/O parameters, validated: FG speed sensor, faults, disturbances, markers.

Their declarations (defaults, units, ranges) are the ``speed_sensor.*``, ``fault.*``,
``disturbance.*`` and ``visualization.*`` entries of
:data:`abb_ros.nodes.simulator.params.SIMULATOR_SPECS`; :func:`hil_settings` turns their
values into a :class:`HilSettings` or raises ParamError naming the parameter. Semantics:
docs/ros_api.md, 'Bench: measured speed, faults, disturbances, markers'.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from abb_ros.model.parameters.params import ParamError
from abb_ros.model.sensors.speed_sensor import SpeedSensorConfig

__all__ = ['HilSettings', 'hil_settings']


@dataclass(frozen=True)
class HilSettings:
    """Validated HIL I/O parameters (SI; the disc angle in degrees as given)."""

    speed_sensor: SpeedSensorConfig = SpeedSensorConfig()
    imu_dropout: bool = False
    imu_stuck: bool = False
    imu_accel_bias_step: tuple[float, float, float] = (0.0, 0.0, 0.0)
    imu_gyro_bias_step: tuple[float, float, float] = (0.0, 0.0, 0.0)
    speed_dropout: bool = False
    speed_noise: float = 0.0
    shock_velocity: tuple[float, ...] = (0.0,) * 6
    disc_eps: float = 0.25e-3
    disc_angle_deg: float = 0.0
    visualization_rate_hz: float = 20.0
    visualization_exaggeration: float = 100.0


def _vector(values: Mapping[str, Any], name: str, size: int, unit: str) -> tuple[float, ...]:
    v = values[name]
    if len(v) != size or not all(math.isfinite(x) for x in v):
        raise ParamError(name, list(v), f'{size} finite values [{unit}]')
    return tuple(float(x) for x in v)


def hil_settings(values: Mapping[str, Any]) -> HilSettings:
    """Build HilSettings from a flat {ROS name: value} mapping; raises ParamError."""
    for name in ('speed_sensor.timer_hz', 'speed_sensor.timeout'):
        if not values[name] > 0:
            raise ParamError(name, values[name], '(0, inf)')
    speed = SpeedSensorConfig(pulses_per_rev=int(values['speed_sensor.pulses_per_rev']),
                              timer_hz=float(values['speed_sensor.timer_hz']),
                              edge_jitter=float(values['speed_sensor.edge_jitter']),
                              timeout=float(values['speed_sensor.timeout']),
                              pitch_error=float(values['speed_sensor.pitch_error']))
    return HilSettings(
        speed_sensor=speed,
        imu_dropout=bool(values['fault.imu_dropout']),
        imu_stuck=bool(values['fault.imu_stuck']),
        imu_accel_bias_step=_vector(values, 'fault.imu_accel_bias_step', 3, 'm/s^2'),
        imu_gyro_bias_step=_vector(values, 'fault.imu_gyro_bias_step', 3, 'rad/s'),
        speed_dropout=bool(values['fault.speed_dropout']),
        speed_noise=float(values['fault.speed_noise']),
        shock_velocity=_vector(values, 'disturbance.shock_velocity', 6,
                               'm/s, m/s, m/s, rad/s, rad/s, rad/s'),
        disc_eps=float(values['disturbance.disc_eps']),
        disc_angle_deg=float(values['disturbance.disc_angle_deg']),
        visualization_rate_hz=float(values['visualization.rate_hz']),
        visualization_exaggeration=float(values['visualization.exaggeration']))

"""Sensor faults for hardware-in-the-loop tests: the IMU's and the FG speed sensor's.

Applied to the readings after the sensor models (:mod:`abb_ros.model.sensors.imu`,
:mod:`abb_ros.model.sensors.speed_sensor`), which keep running underneath: their noise generators
advance whether a fault is active or not, so clearing a fault gives back exactly the
readings of a run without it.

IMU (:class:`ImuFaults`):
  dropout         no reading (no ``deck/imu`` message) while active;
  stuck           the last reading given out before the fault, repeated;
  accel_bias_step added to the specific force [m/s^2] (3 values, deck axes);
  gyro_bias_step  added to the angular rate [rad/s] (3 values, deck axes).
Dropout wins over stuck; stuck repeats the reading as given out (with any bias step then
active).

Speed sensor (:class:`SpeedFaults`):
  dropout   no reading (no ``spindle/speed`` message) while active;
  noise     Gaussian noise of this standard deviation [rad/s] added to each reading, from
            its own generator ``default_rng([seed, 2])``, drawn at every reading.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from abb_ros.model.sensors.imu import ImuReading
from abb_ros.model.sensors.normals import NormalStream

__all__ = ['ImuFaults', 'SpeedFaults', 'NOISE_SEED_STREAM']

NOISE_SEED_STREAM = 2
"""Second seed word of the speed-noise generator (the FG jitter uses 1, the IMU none)."""


@dataclass
class ImuFaults:
    """Active IMU faults (see the module docstring)."""

    dropout: bool = False
    stuck: bool = False
    accel_bias_step: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gyro_bias_step: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        self.reset()

    def reset(self) -> None:
        """Forget the last reading given out (what a stuck IMU would repeat)."""
        self._last: ImuReading | None = None

    def active(self) -> dict[str, object]:
        """Return {fault name: setting} of the faults now active."""
        out = {}
        if self.dropout:
            out['imu_dropout'] = True
        if self.stuck:
            out['imu_stuck'] = True
        if any(self.accel_bias_step):
            out['imu_accel_bias_step'] = list(self.accel_bias_step)
        if any(self.gyro_bias_step):
            out['imu_gyro_bias_step'] = list(self.gyro_bias_step)
        return out

    def apply(self, reading: ImuReading) -> ImuReading | None:
        """Return the reading given out for the sensor's ``reading`` (None: nothing)."""
        if self.dropout:
            return None
        if self.stuck and self._last is not None:
            return self._last
        if any(self.accel_bias_step) or any(self.gyro_bias_step):
            reading = ImuReading(reading.accel + np.asarray(self.accel_bias_step),
                                 reading.gyro + np.asarray(self.gyro_bias_step))
        self._last = reading
        return reading


@dataclass
class SpeedFaults:
    """Active speed-sensor faults (see the module docstring)."""

    dropout: bool = False
    noise: float = 0.0
    seed: int = 0

    def __post_init__(self):
        self.reset()

    def reset(self) -> None:
        """Re-seed the noise generator."""
        self.rng = np.random.default_rng([self.seed, NOISE_SEED_STREAM])
        self._normals = NormalStream(self.rng)

    def active(self) -> dict[str, object]:
        """Return {fault name: setting} of the faults now active."""
        out = {}
        if self.dropout:
            out['speed_dropout'] = True
        if self.noise > 0.0:
            out['speed_noise'] = self.noise
        return out

    def apply(self, value: float) -> float | None:
        """Return the reading given out for the sensor's ``value`` [rad/s] (None: nothing)."""
        z = float(self._normals.take(1)[0])
        if self.dropout:
            return None
        return value + z * self.noise if self.noise > 0.0 else value

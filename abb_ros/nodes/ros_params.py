"""The simulator's ROS parameters: declaration with descriptors, and validation.

``drive.<name>`` are the physical parameters of :class:`abb_ros.model.params.DriveParams`
(SI, Table 1 defaults, the same names as config/cdrom_table1.yaml); the node's own
parameters are listed in :data:`NODE_PARAMS`. :func:`settings_from` turns a flat mapping of
parameter values into validated (DriveParams, SimSettings) and raises ParamError: the
set-parameters callback uses it on the proposed values merged with the current ones, so
a change is refused with the same text the CLI prints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, Mapping

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)

from abb_ros.model.params import PARAM_SPECS, DriveParams, ParamError
from abb_ros.model.integrate import DEFAULT_DT
from abb_ros.model.sensors import TYPICAL_IMU, ImuConfig
from abb_ros.nodes.bench_settings import BenchSettings, bench_settings

__all__ = ['DRIVE_PREFIX', 'NODE_PARAMS', 'SimSettings', 'declare_all', 'settings_from',
           'current_values', 'validate_change', 'P3_WBAR']

DRIVE_PREFIX = 'drive.'
P3_WBAR = 2.7
"""Default initial speed: the paper's point P3, wbar = 2.7 (with the drive's omega0)."""


@dataclass(frozen=True)
class _P:
    default: Any
    description: str
    low: float | None = None
    high: float | None = None
    read_only: bool = False


_INF = math.inf
NODE_PARAMS: dict[str, _P] = {
    'integration_rate_hz': _P(int(round(1.0 / DEFAULT_DT)), 'fixed RK4 step rate [Hz]; 1e9 '
                              'must be a multiple of '
                              'it (integer-nanosecond step); fixed at start-up', 10, 10**7,
                              read_only=True),
    'publish_rate_hz': _P(1000, 'rate of joint_states, deck/pose, deck/twist and /clock [Hz]; '
                          'must divide integration_rate_hz', 1, 10**6),
    'real_time_factor': _P(1.0, 'simulated seconds per wall second (1 = wall clock, HIL); '
                           '0 = as fast as possible []', 0.0, 1000.0),
    'start_paused': _P(False, 'start with integration paused (use ~/pause, ~/step)',
                       read_only=True),
    'max_spindle_speed': _P(1500.0, 'largest accepted spindle/speed_cmd [rad/s]', 0.0, _INF),
    'spindle.initial_speed': _P(None, 'spindle speed at start and after ~/reset [rad/s]; '
                                'default wbar = 2.7 (P3) with the drive omega0', 0.0, _INF),
    'spindle.max_accel': _P(2000.0, 'spindle motor acceleration limit [rad/s^2]', 0.0, _INF),
    'spindle.tau': _P(0.05, 'spindle motor speed-loop time constant [s]', 0.0, _INF),
    'seed': _P(0, 'seed of the IMU noise generator (applies on ~/reset)', 0, 2**31 - 1),
    'imu.rate_hz': _P(int(TYPICAL_IMU.rate), 'IMU output rate [Hz]; must divide '
                      'integration_rate_hz', 1, 10**6),
    'imu.position': _P([0.0, 0.0, 0.0], 'IMU mounting point on the deck, deck axes from C '
                       '[m] (3 finite values)'),
    'imu.gravity': _P(False, 'add gravity (-Z of base) to the specific force (the paper '
                      'neglects it)'),
    'imu.accel_noise_density': _P(TYPICAL_IMU.accel_noise_density,
                                  'accelerometer white noise [m/s^2/sqrt(Hz)]', 0.0, _INF),
    'imu.accel_bias': _P(TYPICAL_IMU.accel_bias, 'accelerometer turn-on bias std [m/s^2]',
                         0.0, _INF),
    'imu.accel_bias_random_walk': _P(TYPICAL_IMU.accel_bias_random_walk,
                                     'accelerometer bias random walk [m/s^3/sqrt(Hz)]',
                                     0.0, _INF),
    'imu.gyro_noise_density': _P(TYPICAL_IMU.gyro_noise_density,
                                 'gyro white noise [rad/s/sqrt(Hz)]', 0.0, _INF),
    'imu.gyro_bias': _P(TYPICAL_IMU.gyro_bias, 'gyro turn-on bias std [rad/s]', 0.0, _INF),
    'imu.gyro_bias_random_walk': _P(TYPICAL_IMU.gyro_bias_random_walk,
                                    'gyro bias random walk [rad/s^2/sqrt(Hz)]', 0.0, _INF),
    # ---- bench: FG speed sensor, faults, disturbances, markers (nodes/bench_settings.py)
    'speed_sensor.pulses_per_rev': _P(6, 'FG pulses per spindle revolution (3 per pole '
                                      'pair of a BLDC motor) []', 1, 1000),
    'speed_sensor.timer_hz': _P(1.0e6, 'FG edge capture timer clock [Hz] (quantisation)',
                                0.0, _INF),
    'speed_sensor.edge_jitter': _P(1.0e-6, 'FG edge time jitter, standard deviation [s]',
                                   0.0, _INF),
    'speed_sensor.timeout': _P(0.1, 'no FG edge for this long reads 0 rad/s [s]', 0.0, _INF),
    'fault.imu_dropout': _P(False, 'IMU dropout: no deck/imu messages while true'),
    'fault.imu_stuck': _P(False, 'IMU stuck: deck/imu repeats its last reading while true'),
    'fault.imu_accel_bias_step': _P([0.0, 0.0, 0.0], 'bias step added to deck/imu specific '
                                    'force, deck axes [m/s^2] (3 finite values)'),
    'fault.imu_gyro_bias_step': _P([0.0, 0.0, 0.0], 'bias step added to deck/imu angular '
                                   'rate, deck axes [rad/s] (3 finite values)'),
    'fault.speed_dropout': _P(False, 'speed sensor dropout: no spindle/speed while true'),
    'fault.speed_noise': _P(0.0, 'white noise added to spindle/speed, std [rad/s]', 0.0, _INF),
    'disturbance.shock_velocity': _P([0.0] * 6, 'deck twist step of ~/apply_shock, deck axes '
                                     '[m/s, m/s, m/s, rad/s, rad/s, rad/s] (6 finite values)'),
    'disturbance.disc_eps': _P(0.25e-3, 'eccentricity eps of the disc put in by ~/swap_disc '
                               '[m] (becomes drive.eps)', 0.0, 1.0),
    'disturbance.disc_angle_deg': _P(0.0, 'imbalance angle of the disc put in by ~/swap_disc, '
                                     'relative to the current one [deg]', -360.0, 360.0),
    'visualization.rate_hz': _P(20.0, 'visualization/markers rate, simulated time [Hz]; 0 '
                                '= off', 0.0, 1000.0),
    'visualization.exaggeration': _P(100.0, 'deck displacement and tilt scale factor in '
                                     'visualization/markers []', 0.0, 1.0e6),
}
"""The node's own parameters: default, description with units, closed range, read-only."""


@dataclass(frozen=True)
class SimSettings:
    """The node's own parameters, validated. Rates in Hz, speeds in rad/s."""

    integration_rate_hz: int
    publish_rate_hz: int
    real_time_factor: float
    start_paused: bool
    max_spindle_speed: float
    initial_speed: float
    spindle_max_accel: float
    spindle_tau: float
    seed: int
    imu: ImuConfig
    bench: BenchSettings = BenchSettings()

    @property
    def dt_ns(self) -> int:
        return 1_000_000_000 // self.integration_rate_hz

    @property
    def publish_every(self) -> int:
        return self.integration_rate_hz // self.publish_rate_hz

    @property
    def imu_every(self) -> int:
        return self.integration_rate_hz // int(self.imu.rate)


def descriptor(name: str, spec: _P) -> ParameterDescriptor:
    d = ParameterDescriptor(description=spec.description, read_only=spec.read_only)
    if spec.low is None:
        return d
    if isinstance(spec.low, int) and not isinstance(spec.default, float):
        d.integer_range = [IntegerRange(from_value=int(spec.low), to_value=int(spec.high),
                                        step=0)]
    else:
        d.floating_point_range = [FloatingPointRange(from_value=float(spec.low),
                                                     to_value=float(spec.high), step=0.0)]
    return d


def drive_descriptor(name: str) -> ParameterDescriptor:
    spec = PARAM_SPECS[name]
    d = ParameterDescriptor(description=f'{spec.description} [{spec.unit or "-"}]; valid '
                            f'{spec.valid_text()}' + ('; a change applies on ~/reset'
                                                      if name == 'n' else ''))
    if name == 'n':
        d.integer_range = [IntegerRange(from_value=int(spec.low), to_value=int(spec.high),
                                        step=1)]
    else:
        # ROS ranges are closed; an open bound (e.g. k > 0) is checked by DriveParams.
        d.floating_point_range = [FloatingPointRange(from_value=float(spec.low),
                                                     to_value=float(spec.high), step=0.0)]
    return d


def declare_all(node) -> tuple[DriveParams, SimSettings]:
    """Declare every parameter on ``node`` (overrides from --params-file / -p win over the
    defaults) and return them validated; raises ParamError for invalid start-up values."""
    defaults = DriveParams()
    for f in fields(DriveParams):
        node.declare_parameter(DRIVE_PREFIX + f.name, getattr(defaults, f.name),
                               drive_descriptor(f.name))
    drive = DriveParams.from_mapping(
        {f.name: node.get_parameter(DRIVE_PREFIX + f.name).value for f in fields(DriveParams)})
    for name, spec in NODE_PARAMS.items():
        default = spec.default
        if name == 'spindle.initial_speed':
            default = P3_WBAR * drive.omega0
        node.declare_parameter(name, default, descriptor(name, spec))
    return settings_from(current_values(node))


def current_values(node) -> dict[str, Any]:
    """Every simulator parameter's current value, by ROS name."""
    names = [DRIVE_PREFIX + f.name for f in fields(DriveParams)] + list(NODE_PARAMS)
    return {name: node.get_parameter(name).value for name in names}


def settings_from(values: Mapping[str, Any]) -> tuple[DriveParams, SimSettings]:
    """Validated parameters from a flat {ROS name: value} mapping; raises ParamError."""
    drive = DriveParams.from_mapping(
        {k[len(DRIVE_PREFIX):]: v for k, v in values.items() if k.startswith(DRIVE_PREFIX)})
    rate = int(values['integration_rate_hz'])
    if 1_000_000_000 % rate:
        raise ParamError('integration_rate_hz', rate, 'a divisor of 1e9 (e.g. 10000, 20000, '
                         '40000, 50000)', 'the step must be a whole number of nanoseconds')
    for name in ('publish_rate_hz', 'imu.rate_hz'):
        if rate % int(values[name]):
            raise ParamError(name, values[name], f'a divisor of integration_rate_hz = {rate}')
    position = values['imu.position']
    if len(position) != 3 or not all(math.isfinite(x) for x in position):
        raise ParamError('imu.position', list(position), '3 finite values [m]')
    for name in ('spindle.max_accel', 'spindle.tau'):
        if values[name] <= 0:
            raise ParamError(name, values[name], f'(0, inf) {NODE_PARAMS[name].description}')
    if values['spindle.initial_speed'] > values['max_spindle_speed']:
        raise ParamError('spindle.initial_speed', values['spindle.initial_speed'],
                         f'[0, max_spindle_speed = {values["max_spindle_speed"]:g}] rad/s')
    imu = ImuConfig(position=tuple(float(x) for x in position),
                    rate=float(values['imu.rate_hz']), gravity=bool(values['imu.gravity']),
                    **{k: float(values['imu.' + k]) for k in (
                        'accel_noise_density', 'accel_bias', 'accel_bias_random_walk',
                        'gyro_noise_density', 'gyro_bias', 'gyro_bias_random_walk')})
    settings = SimSettings(
        integration_rate_hz=rate, publish_rate_hz=int(values['publish_rate_hz']),
        real_time_factor=float(values['real_time_factor']),
        start_paused=bool(values['start_paused']),
        max_spindle_speed=float(values['max_spindle_speed']),
        initial_speed=float(values['spindle.initial_speed']),
        spindle_max_accel=float(values['spindle.max_accel']),
        spindle_tau=float(values['spindle.tau']), seed=int(values['seed']), imu=imu,
        bench=bench_settings(values))
    return drive, settings


def validate_merged(values: dict, parameters, build) -> SetParametersResult:
    """The proposed ``parameters`` merged into ``values`` ({ROS name: value}) must be accepted
    by ``build(values)`` (which raises ParamError otherwise). No side effects."""
    values = dict(values)
    for p in parameters:
        if p.name in values:
            values[p.name] = p.value
    try:
        build(values)
    except ParamError as err:
        return SetParametersResult(successful=False, reason=str(err))
    except (TypeError, ValueError) as err:
        return SetParametersResult(successful=False, reason=f'invalid parameter: {err}')
    return SetParametersResult(successful=True)


def validate_change(node, parameters) -> SetParametersResult:
    """on-set-parameters callback body: the proposed values merged with the current ones
    must make valid settings. No side effects."""
    return validate_merged(current_values(node), parameters, settings_from)

"""The plant's parameters besides the drive: step and publish rates, spindle, IMU, motor.

The simulator node declares them; the headless ``abb-sim run`` takes those with ``run`` in
``commands`` through ``--set`` (:func:`cli_names`), and the example controller the motor's.
:func:`imu_config` and :func:`check_rates` turn {ROS name: value} into the model's settings.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from abb_ros.model.parameters.drive_spec import DRIVE_NODES, DRIVE_SPECS
from abb_ros.model.parameters.param_spec import BOOL, DOUBLE_ARRAY, INTEGER, ParamError, ParamSpec
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuConfig

__all__ = ['STEP_SPECS', 'MAX_SPINDLE_SPEED', 'SPINDLE_SPECS', 'SEED', 'IMU_SPECS',
           'MOTOR_DEFAULTS', 'MOTOR_SPECS', 'PLANT_SPECS', 'PLANT', 'spec_for_command',
           'cli_names', 'imu_config', 'check_rates']

_INF = math.inf
_AT_STEP = 'at the next step'
_SIM = ('simulator',)
_MOTOR = ('simulator', 'spin_controller')
"""The nodes that take the motor's parameters (motor.*)."""
_RUN = ('run',)

STEP_SPECS = (
    ParamSpec('integration_rate_hz', 10000, 'Hz', 'fixed RK4 step rate; 1e9 must be a '
              'multiple of it (integer-nanosecond step)', INTEGER, 10, 10**7, read_only=True,
              applies='at start-up', nodes=_SIM, commands=_RUN),
    ParamSpec('publish_rate_hz', 1000, 'Hz', 'rate of joint_states, deck/pose, deck/twist and '
              '/clock; must divide integration_rate_hz', INTEGER, 1, 10**6, applies=_AT_STEP,
              nodes=_SIM, commands=_RUN),
)
"""The fixed integration step and the rate of the state topics."""

MAX_SPINDLE_SPEED = ParamSpec(
    'max_spindle_speed', 1500.0, 'rad/s', 'largest accepted spindle/speed_cmd (the analysis: '
    'top of its speed table, > 0)', low=0.0, high=_INF, applies=_AT_STEP, nodes=DRIVE_NODES)
"""The spindle's speed limit, shared by the nodes that take the drive."""

SPINDLE_SPECS = (
    ParamSpec('spindle.initial_speed', None, 'rad/s', 'spindle speed at start and after '
              '~/reset; default wbar = 2.7 (P3) with the drive omega0; at most '
              'max_spindle_speed', low=0.0, high=_INF, applies='on ~/reset', nodes=_SIM,
              commands=_RUN),
    ParamSpec('spindle.max_accel', 2000.0, 'rad/s^2', 'spindle motor acceleration limit',
              low=0.0, low_open=True, high=_INF, applies=_AT_STEP, nodes=_SIM, commands=_RUN),
    ParamSpec('spindle.tau', 0.05, 's', 'spindle motor speed-loop time constant', low=0.0,
              low_open=True, high=_INF, applies=_AT_STEP, nodes=_SIM, commands=_RUN),
)
"""The spindle's start speed and its speed loop (speed mode)."""

SEED = ParamSpec('seed', 0, '', 'seed of the IMU noise generator', INTEGER, 0, 2**31 - 1,
                 applies='on ~/reset', nodes=_SIM, commands=_RUN)
"""The seed of the plant's random draws (IMU noise, FG pitch pattern)."""


def _imu(field, unit, description):
    return ParamSpec('imu.' + field, getattr(TYPICAL_IMU, field), unit, description,
                     low=0.0, high=_INF, applies=_AT_STEP, nodes=_SIM, commands=_RUN)


IMU_SPECS = (
    ParamSpec('imu.rate_hz', int(TYPICAL_IMU.rate), 'Hz', 'IMU output rate; must divide '
              'integration_rate_hz', INTEGER, 1, 10**6, applies=_AT_STEP, nodes=_SIM,
              commands=_RUN),
    ParamSpec('imu.position', [0.0, 0.0, 0.0], 'm', 'IMU mounting point on the deck, deck '
              'axes from C', DOUBLE_ARRAY, length=3, applies=_AT_STEP, nodes=_SIM,
              commands=_RUN),
    ParamSpec('imu.gravity', False, '', 'add gravity (-Z of base) to the specific force (the '
              'paper neglects it)', BOOL, applies=_AT_STEP, nodes=_SIM, commands=_RUN),
    _imu('accel_noise_density', 'm/s^2/sqrt(Hz)', 'accelerometer white noise'),
    _imu('accel_bias', 'm/s^2', 'accelerometer turn-on bias std'),
    _imu('accel_bias_random_walk', 'm/s^3/sqrt(Hz)', 'accelerometer bias random walk'),
    _imu('gyro_noise_density', 'rad/s/sqrt(Hz)', 'gyro white noise'),
    _imu('gyro_bias', 'rad/s', 'gyro turn-on bias std'),
    _imu('gyro_bias_random_walk', 'rad/s^2/sqrt(Hz)', 'gyro bias random walk'),
)
"""The IMU on the deck (:class:`abb_ros.model.sensors.imu.ImuConfig`)."""

MOTOR_DEFAULTS = dict(torque_constant=0.01, resistance=2.0, current_limit=1.0,
                      voltage_limit=12.0, viscous_friction=1.0e-7, coulomb_friction=1.0e-4,
                      friction_smoothing=1.0)
"""The spindle motor of torque mode (``motor.*``, docs/torque_mode.md): a small DC/BLDC
spindle motor of an optical drive."""


def _motor(field, unit, description, low_open=True):
    return ParamSpec('motor.' + field, MOTOR_DEFAULTS[field], unit, description, low=0.0,
                     low_open=low_open, high=_INF, applies=_AT_STEP, nodes=_MOTOR)


MOTOR_SPECS = (
    _motor('torque_constant', 'N m/A', 'K_t; the back-EMF constant K_e = K_t [V s/rad]'),
    _motor('resistance', 'ohm', 'winding resistance R_w'),
    _motor('current_limit', 'A', 'drive current limit I_max (commands beyond it saturate)'),
    _motor('voltage_limit', 'V', 'supply voltage V_s: |R_w i + K_t omega| <= V_s'),
    _motor('viscous_friction', 'N m s', 'bearing viscous friction b_v', low_open=False),
    _motor('coulomb_friction', 'N m', 'bearing Coulomb friction T_c', low_open=False),
    _motor('friction_smoothing', 'rad/s', 'speed omega_c of T_c tanh(omega / omega_c)'),
)
"""The spindle motor of torque mode."""

PLANT_SPECS = STEP_SPECS + (MAX_SPINDLE_SPEED,) + SPINDLE_SPECS + (SEED,) + IMU_SPECS \
    + MOTOR_SPECS
"""Every plant parameter besides the drive's."""
PLANT: dict[str, ParamSpec] = {s.name: s for s in PLANT_SPECS}
"""{ROS name: spec} of :data:`PLANT_SPECS`."""

_COMMAND_SPECS = tuple(s for s in DRIVE_SPECS + PLANT_SPECS if s.commands)


def spec_for_command(command: str, name: str) -> ParamSpec | None:
    """Return the spec ``--set name=...`` of ``abb-sim command`` refers to (drive: SI name)."""
    for s in _COMMAND_SPECS:
        if command in s.commands and name in (s.short, s.name):
            return s
    return None


def cli_names(command: str) -> list[str]:
    """Return the names ``abb-sim command --set`` accepts (besides omega and Eq. 39 names)."""
    return [s.short for s in _COMMAND_SPECS if command in s.commands]


def imu_config(values: Mapping[str, Any]) -> ImuConfig:
    """Return the ImuConfig of {ROS name: value}; a missing ``imu.*`` takes the spec default."""
    def get(name):
        return values[name] if name in values else PLANT[name].default

    return ImuConfig(position=tuple(float(x) for x in get('imu.position')),
                     rate=float(get('imu.rate_hz')), gravity=bool(get('imu.gravity')),
                     **{k: float(get('imu.' + k)) for k in (
                         'accel_noise_density', 'accel_bias', 'accel_bias_random_walk',
                         'gyro_noise_density', 'gyro_bias', 'gyro_bias_random_walk')})


def check_rates(values: Mapping[str, Any]) -> None:
    """Check that the step is whole nanoseconds and the publish and IMU rates divide it.

    ``values`` is {ROS name: value}; a missing name takes the spec default. Raises ParamError.
    """
    rate, publish, imu = (int(values.get(k, PLANT[k].default)) for k in (
        'integration_rate_hz', 'publish_rate_hz', 'imu.rate_hz'))
    if 1_000_000_000 % rate:
        raise ParamError('integration_rate_hz', rate, 'a divisor of 1e9 (e.g. 10000, 20000, '
                         '40000, 50000)', 'the step must be a whole number of nanoseconds')
    for name, value in (('publish_rate_hz', publish), ('imu.rate_hz', imu)):
        if rate % value:
            raise ParamError(name, value, f'a divisor of integration_rate_hz = {rate}')

"""The plant's parameters besides the drive: step and publish rates, spindle, IMU, motor.

The simulator node declares them, the headless ``abb-sim run`` takes most of them through
``--set`` (:mod:`abb_ros.commands.settings`), the example controller the motor's.
:func:`imu_config` and :func:`check_rates` turn {ROS name: value} into the model's settings.
"""

from __future__ import annotations

from typing import Any, Mapping

from abb_ros.model.parameters.drive_spec import MAX_OMEGA
from abb_ros.model.parameters.param_spec import BOOL, DOUBLE_ARRAY, INTEGER, ParamError, ParamSpec
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuConfig

__all__ = ['STEP_SPECS', 'MAX_SPINDLE_SPEED', 'IMU_FULL_SCALE', 'SPINDLE_SPECS', 'SEED',
           'IMU_SPECS', 'MOTOR_DEFAULTS', 'MOTOR_SPAN', 'MOTOR_SPECS', 'PLANT_SPECS', 'PLANT',
           'imu_config', 'check_rates', 'step_of']

_AT_STEP = 'at the next step'

STEP_SPECS = (
    ParamSpec('integration_rate_hz', 10000, 'Hz', 'fixed RK4 step rate; 1e9 must be a '
              'multiple of it (integer-nanosecond step)', INTEGER, 10, 10**7, read_only=True,
              applies='at start-up'),
    ParamSpec('publish_rate_hz', 1000, 'Hz', 'rate of joint_states, deck/pose, deck/twist and '
              '/clock; must divide integration_rate_hz', INTEGER, 1, 10**6, applies=_AT_STEP),
)
"""The fixed integration step and the rate of the state topics."""

MAX_SPINDLE_SPEED = ParamSpec(
    'max_spindle_speed', 1500.0, 'rad/s', 'largest accepted spindle/speed_cmd (the analysis: '
    'top of its speed table, > 0); at most the model\'s speed limit MAX_OMEGA', low=0.0,
    high=MAX_OMEGA, applies=_AT_STEP)
"""The spindle's speed limit, shared by the nodes that take the drive."""

SPINDLE_SPECS = (
    ParamSpec('spindle.initial_speed', None, 'rad/s', 'spindle speed at start and after '
              '~/reset; default wbar = 2.7 (P3) with the drive omega0; at most '
              'max_spindle_speed', low=0.0, high=MAX_OMEGA, applies='on ~/reset'),
    ParamSpec('spindle.max_accel', 2000.0, 'rad/s^2', 'spindle motor acceleration limit; at '
              'most 1e9 (MAX_OMEGA within 0.1 ms, one default step)', low=0.0, low_open=True,
              high=1e9, applies=_AT_STEP),
    ParamSpec('spindle.tau', 0.05, 's', 'spindle motor speed-loop time constant; at least '
              '1e-9 s (one nanosecond, the stamps\' resolution: (command - speed) / tau stays '
              'finite), at most an hour', low=1e-9, high=3600.0, applies=_AT_STEP),
)
"""The spindle's start speed and its speed loop (speed mode)."""

SEED = ParamSpec('seed', 0, '', 'seed of the IMU noise generator', INTEGER, 0, 2**31 - 1,
                 applies='on ~/reset')
"""The seed of the plant's random draws (IMU noise, FG pitch pattern)."""


def _imu(field, unit, description, high):
    return ParamSpec('imu.' + field, getattr(TYPICAL_IMU, field), unit, description,
                     low=0.0, high=high, applies=_AT_STEP)


IMU_FULL_SCALE = (1000.0, 100.0)
"""Largest specific force [m/s^2] (about 100 g) and angular rate [rad/s] the IMU parameters
may produce: ten times the full scale of a MEMS accelerometer (16 g) and gyro (2000 deg/s =
35 rad/s). Bounding the noise, the biases and the bias steps by them keeps every deck/imu
reading and covariance finite (a noise density of 1e200 once overflowed its variance)."""
_A_MAX, _G_MAX = IMU_FULL_SCALE
_MAX_IMU_RATE = 1e6
"""The fastest imu.rate_hz [Hz]: a noise density d gives a per-sample std d sqrt(rate), so
d <= full scale / sqrt(1e6) keeps the white noise within the full scale at any rate."""
_IMU_BOUND = ('; at most {:g}, so that the reading stays within the full scale '
              'IMU_FULL_SCALE')


IMU_SPECS = (
    ParamSpec('imu.rate_hz', int(TYPICAL_IMU.rate), 'Hz', 'IMU output rate; must divide '
              'integration_rate_hz', INTEGER, 1, int(_MAX_IMU_RATE), applies=_AT_STEP),
    ParamSpec('imu.position', [0.0, 0.0, 0.0], 'm', 'IMU mounting point on the deck, deck '
              'axes from C; within 1 m of C (the deck is 70 mm x 110 mm; farther, w x (w x '
              'r) of the rotating deck is no longer a deck-mounted sensor)', DOUBLE_ARRAY,
              length=3, low=-1.0, high=1.0, applies=_AT_STEP),
    ParamSpec('imu.gravity', False, '', 'add gravity (-Z of base) to the specific force (the '
              'paper neglects it)', BOOL, applies=_AT_STEP),
    _imu('accel_noise_density', 'm/s^2/sqrt(Hz)', 'accelerometer white noise'
         + _IMU_BOUND.format(_A_MAX / _MAX_IMU_RATE ** 0.5) + ' at the fastest imu.rate_hz',
         _A_MAX / _MAX_IMU_RATE ** 0.5),
    _imu('accel_bias', 'm/s^2', 'accelerometer turn-on bias std' + _IMU_BOUND.format(_A_MAX),
         _A_MAX),
    _imu('accel_bias_random_walk', 'm/s^3/sqrt(Hz)', 'accelerometer bias random walk; at most '
         f'{_A_MAX:g}, a full scale in a second', _A_MAX),
    _imu('gyro_noise_density', 'rad/s/sqrt(Hz)', 'gyro white noise'
         + _IMU_BOUND.format(_G_MAX / _MAX_IMU_RATE ** 0.5) + ' at the fastest imu.rate_hz',
         _G_MAX / _MAX_IMU_RATE ** 0.5),
    _imu('gyro_bias', 'rad/s', 'gyro turn-on bias std' + _IMU_BOUND.format(_G_MAX), _G_MAX),
    _imu('gyro_bias_random_walk', 'rad/s^2/sqrt(Hz)', 'gyro bias random walk; at most '
         f'{_G_MAX:g}, a full scale in a second', _G_MAX),
)
"""The IMU on the deck (:class:`abb_ros.model.sensors.imu.ImuConfig`)."""

MOTOR_DEFAULTS = dict(torque_constant=0.01, resistance=2.0, current_limit=1.0,
                      voltage_limit=12.0, viscous_friction=1.0e-7, coulomb_friction=1.0e-4,
                      friction_smoothing=1.0)
"""The spindle motor of torque mode (``motor.*``, docs/torque_mode.md): a small DC/BLDC
spindle motor of an optical drive."""


MOTOR_SPAN = 1000.0
"""How far a motor parameter may exceed its default (a small disc-drive spindle motor): a
thousand times covers any motor that fits a deck, and keeps the torque and the current of
torque mode finite."""


def _motor(field, unit, description, low_open=True):
    high = MOTOR_DEFAULTS[field] * MOTOR_SPAN
    return ParamSpec('motor.' + field, MOTOR_DEFAULTS[field], unit,
                     f'{description}; at most {high:g} (MOTOR_SPAN times the default)', low=0.0,
                     low_open=low_open, high=high, applies=_AT_STEP)


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


def step_of(rate_hz: int) -> tuple[int, float]:
    """Return the fixed integration step of ``rate_hz``, a divisor of 1e9 (:func:`check_rates`).

    The one place the step is derived from the rate, for the nodes and the command line.

    Returns
    -------
    dt_ns : int
        The step [ns].
    dt : float
        The same step [s]: ``dt_ns / 1e9``, which equals ``1 / rate_hz`` for every divisor of
        1e9 (``dt_ns * 1e-9`` would not, e.g. at 15625 Hz).
    """
    dt_ns = 1_000_000_000 // int(rate_hz)
    return dt_ns, dt_ns / 1e9

"""Every parameter of abb_ros, specified once: name, default, unit, range, type, where it applies.

One :class:`ParamSpec` per parameter; :data:`SPECS` lists them all. Derived from it:

* the drive parameters :class:`abb_ros.model.params.DriveParams` (SI, Table 1 defaults);
* the ROS parameter descriptors and the declare loop of the nodes
  (:mod:`abb_ros.nodes.ros_params`);
* the validation: :meth:`ParamSpec.check`, one :class:`ParamError` text everywhere;
* the names ``abb-sim`` accepts with ``--set`` (:func:`cli_names`);
* the parameter table docs/parameters.md
  (``python -m abb_ros.model.param_spec --markdown > docs/parameters.md``).

Pure Python (no rclpy): the model layer.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from typing import Any, Iterable, Mapping

from abb_ros.model.sensors import TYPICAL_IMU, ImuConfig

__all__ = [
    'ParamError', 'ParamSpec', 'SPECS', 'DRIVE_PREFIX', 'DRIVE_SPECS', 'CONTROLLER_SPECS',
    'NODES', 'COMMANDS',
    'specs_for', 'spec_for_command', 'cli_names', 'imu_config', 'check_rates', 'markdown',
    'MAX_BALLS', 'RUBBER_C', 'METAL_C',
]

RUBBER_C = 2.53
"""Washer damping c of rubber suspension washers [kg/s] (Table 1)."""
METAL_C = 0.66
"""Washer damping c of metal suspension washers [kg/s] (Table 1)."""
MAX_BALLS = 64
"""Largest ball count accepted (the race of a real drive holds about 10)."""

DRIVE_PREFIX = 'drive.'
NODES = ('simulator', 'analysis', 'recorder', 'spin_controller')
"""Executables with ROS parameters (``ros2 run abb_ros <node>``)."""
COMMANDS = ('run', 'stability', 'freqs', 'map')
"""``abb-sim`` subcommands with ``--set``."""

DOUBLE, INTEGER, BOOL, STRING = 'double', 'integer', 'bool', 'string'
DOUBLE_ARRAY, STRING_ARRAY = 'double_array', 'string_array'


class ParamError(ValueError):
    """A parameter value outside its valid range (or of the wrong type).

    Attributes ``name`` (the parameter), ``value``, ``valid`` (the range, as text) and
    ``why``.
    """

    def renamed(self, name: str) -> 'ParamError':
        """The same error naming ``name`` (e.g. the ROS name drive.k of the SI name k)."""
        return ParamError(name, self.value, self.valid, self.why)

    def __init__(self, name: str, value: Any, valid: str, why: str = ''):
        self.name = name
        self.value = value
        self.valid = valid
        self.why = why
        msg = f'parameter {name!r} = {value!r} is invalid: valid range is {valid}'
        if why:
            msg += f' ({why})'
        super().__init__(msg)


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@dataclass(frozen=True)
class ParamSpec:
    """One parameter. ``name`` is the ROS name (``drive.k``, ``imu.rate_hz``); ``low``/``high``
    bound numbers (None: unbounded), ``*_open`` makes a bound exclusive; ``default`` None is
    computed when declared (documented in ``description``)."""

    name: str
    default: Any
    unit: str
    description: str
    type: str = DOUBLE
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    read_only: bool = False
    applies: str = ''
    nodes: tuple = ()
    commands: tuple = ()
    length: int | None = None
    choices: tuple = ()

    @property
    def short(self) -> str:
        """The name without ``drive.``: the SI name of DriveParams and of ``--set``."""
        return self.name[len(DRIVE_PREFIX):] if self.name.startswith(DRIVE_PREFIX) else self.name

    def valid_text(self) -> str:
        """What is valid, e.g. ``(0, inf) N/m``."""
        if self.type in (DOUBLE, INTEGER):
            low = -math.inf if self.low is None else self.low
            high = math.inf if self.high is None else self.high
            fmt = (lambda x: str(int(x))) if self.type == INTEGER else (lambda x: f'{x:g}')
            lo = '(-inf' if math.isinf(low) else ('(' if self.low_open else '[') + fmt(low)
            hi = 'inf)' if math.isinf(high) else fmt(high) + (')' if self.high_open else ']')
            return f'{lo}, {hi} {self.unit}'.rstrip()
        if self.type == BOOL:
            return 'true or false'
        if self.type == STRING:
            return 'one of ' + ', '.join(self.choices) if self.choices else 'a string'
        if self.type == DOUBLE_ARRAY:
            return f'{self.length} finite values [{self.unit}]'
        return 'a list of strings'

    def check(self, value: Any, name: str | None = None, strict: bool = False) -> Any:
        """``value`` if valid (an int for a double becomes a float); raises ParamError naming
        ``name`` (default: this spec's name). ``strict``: a float for an integer is refused
        even when whole (ROS types), otherwise 2.0 is accepted as 2."""
        name = name or self.name
        if self.type == DOUBLE:
            value = self._number(name, value)
            return float(value) if isinstance(value, int) else value
        if self.type == INTEGER:
            if isinstance(value, float) and not strict and value.is_integer():
                value = int(value)
            if isinstance(value, float):
                raise ParamError(name, value, self.valid_text(), 'not an integer')
            return self._number(name, value)
        if self.type == BOOL:
            if not isinstance(value, bool):
                raise ParamError(name, value, self.valid_text(), 'not true or false')
            return value
        if self.type == STRING:
            if not isinstance(value, str) or (self.choices and value not in self.choices):
                raise ParamError(name, value, self.valid_text())
            return value
        value = _plain(value)
        if self.type == DOUBLE_ARRAY:
            ok = isinstance(value, list) and len(value) == self.length and all(
                _is_number(x) and math.isfinite(x) for x in value)
            if not ok:
                raise ParamError(name, value, self.valid_text())
            return [float(x) for x in value]
        if not (isinstance(value, list) and all(isinstance(x, str) for x in value)):
            raise ParamError(name, value, self.valid_text())
        return value

    def _number(self, name, value):
        if not _is_number(value):
            raise ParamError(name, _plain(value), self.valid_text(), 'not a number')
        if not math.isfinite(value):
            raise ParamError(name, value, self.valid_text(), 'not finite')
        low, high = self.low, self.high
        if (low is not None and (value < low or (self.low_open and value == low))) or \
                (high is not None and (value > high or (self.high_open and value == high))):
            raise ParamError(name, value, self.valid_text())
        return value


def _plain(value):
    """A list for a sequence (rclpy gives array.array for arrays), else the value."""
    if isinstance(value, (str, bytes, dict)) or not hasattr(value, '__len__'):
        return value
    return list(value)


_ALL_CLI = COMMANDS
_BOTH = ('simulator', 'analysis', 'spin_controller')
"""The nodes that take the drive's parameters (and max_spindle_speed)."""
_SIM = ('simulator',)
_MOTOR = ('simulator', 'spin_controller')
"""The nodes that take the motor's parameters (motor.*)."""
_RUN = ('run',)


def _drive(name, default, unit, description, **kw):
    kw.setdefault('low', 0.0)
    kw.setdefault('low_open', True)
    return ParamSpec(DRIVE_PREFIX + name, default, unit, description, nodes=_BOTH,
                     commands=_ALL_CLI, applies='at the next step', **kw)


_NONNEG = dict(low=0.0, low_open=False)

DRIVE_SPECS = (
    _drive('a', 0.070, 'm', 'width of the feeding deck, a'),
    _drive('b', 0.110, 'm', 'length of the feeding deck, b'),
    _drive('d', 0.030, 'm', 'distance between C (spindle axis) and P (deck mass centre), d',
           low=-1.0, low_open=False, high=1.0),
    _drive('R', 0.015, 'm', 'mean (pitch) radius of the ball race, R'),
    _drive('M_P', 0.150, 'kg', 'mass of the feeding-deck assembly, M_P'),
    _drive('M', 0.026, 'kg', 'mass of the equivalent rotor, M'),
    _drive('m', 0.43e-3, 'kg', 'mass of one balancing ball, m'),
    _drive('J_Px', 1.43e-4, 'kg m^2', 'deck moment of inertia about x through P, J_Px'),
    _drive('J_Py', 0.31e-4, 'kg m^2', 'deck moment of inertia about y through P, J_Py'),
    _drive('J_Pz', 1.74e-4, 'kg m^2', 'deck moment of inertia about z through P, J_Pz'),
    _drive('J_x', 1.46e-6, 'kg m^2', 'rotor moment of inertia about x, J_x'),
    _drive('J_y', 1.46e-6, 'kg m^2', 'rotor moment of inertia about y, J_y (equal to J_x)'),
    _drive('J_z', 2.93e-6, 'kg m^2', 'rotor moment of inertia about the spin axis z, J_z'),
    _drive('k', 3972.0, 'N/m', 'stiffness of one suspension washer, k'),
    _drive('c', RUBBER_C, 'kg/s', 'damping of one suspension washer, c (rubber 2.53, metal '
           '0.66)', **_NONNEG),
    _drive('D', 5e-6, 'kg m^2/s', 'viscous drag coefficient of one ball in the race fluid, D',
           **_NONNEG),
    _drive('eps', 0.25e-3, 'm', 'mass eccentricity of the rotor, epsilon', **_NONNEG),
    ParamSpec('drive.n', 2, '', 'number of balancing balls, n (0 = drive without ABB)',
              INTEGER, 0, MAX_BALLS, applies='on ~/reset (simulator)', nodes=_BOTH,
              commands=_ALL_CLI),
    # ---- beyond the paper (docs/beyond_the_paper.md); zero = the paper's model ----
    _drive('r_ball', 0.0, 'm', 'ball radius (0 = point balls, the paper); needed by contact '
           'and rolling resistance', **_NONNEG),
    _drive('contact_E', 0.0, 'Pa', "Young's modulus of the balls for the Hertzian ball-ball "
           'contact (0 = balls pass through each other, the paper; steel 2.0e11)', **_NONNEG),
    _drive('contact_nu', 0.3, '', "Poisson's ratio of the balls (steel 0.3)", low=0.0,
           low_open=False, high=0.5),
    _drive('contact_damping', 0.0, 's/m', 'Hunt-Crossley damping factor chi of the ball-ball '
           "contact: F = K delta^1.5 (1 + chi delta')", **_NONNEG),
    _drive('rolling_mu', 0.0, 'm', 'rolling-resistance coefficient (lever arm) between ball '
           'and race (0 = none, the paper)', **_NONNEG),
    _drive('rolling_stick_rate', 1e-3, 'rad/s', 'least half-width of the Karnopp stick band '
           "of rolling resistance in phi_i' (the band is at least the speed rolling resistance "
           'takes away in 1 ms)'),
    ParamSpec('drive.ball_rotation', 0, '', '1 = the balls roll on the race (their spin '
              'inertia 2/5 m r_ball^2 adds 2/5 m R^2 to the ball mass term), 0 = the paper',
              INTEGER, 0, 1, applies='at the next step', nodes=_BOTH, commands=_ALL_CLI),
)
"""The physical parameters of Table 1 (rubber washers, eps = 0.25 mm, n = 2), SI, and the
optional terms beyond the paper (zero = the paper's model)."""

_INF = math.inf
_AT_STEP = 'at the next step'


def _imu(field, unit, description):
    return ParamSpec('imu.' + field, getattr(TYPICAL_IMU, field), unit, description,
                     low=0.0, high=_INF, applies=_AT_STEP, nodes=_SIM, commands=_RUN)


MOTOR_DEFAULTS = dict(torque_constant=0.01, resistance=2.0, current_limit=1.0,
                      voltage_limit=12.0, viscous_friction=1.0e-7, coulomb_friction=1.0e-4,
                      friction_smoothing=1.0)
"""The spindle motor of torque mode (``motor.*``, docs/torque_mode.md): a small DC/BLDC
spindle motor of an optical drive."""


def _motor(field, unit, description, low_open=True):
    return ParamSpec('motor.' + field, MOTOR_DEFAULTS[field], unit, description, low=0.0,
                     low_open=low_open, high=_INF, applies=_AT_STEP, nodes=_MOTOR)


SIMULATOR_SPECS = (
    ParamSpec('integration_rate_hz', 10000, 'Hz', 'fixed RK4 step rate; 1e9 must be a '
              'multiple of it (integer-nanosecond step)', INTEGER, 10, 10**7, read_only=True,
              applies='at start-up', nodes=_SIM, commands=_RUN),
    ParamSpec('publish_rate_hz', 1000, 'Hz', 'rate of joint_states, deck/pose, deck/twist and '
              '/clock; must divide integration_rate_hz', INTEGER, 1, 10**6, applies=_AT_STEP,
              nodes=_SIM, commands=_RUN),
    ParamSpec('real_time_factor', 1.0, '', 'simulated seconds per wall second (1 = wall '
              'clock, HIL); 0 = as fast as possible', low=0.0, high=1000.0, applies=_AT_STEP,
              nodes=_SIM),
    ParamSpec('start_paused', False, '', 'start with integration paused (use ~/pause, ~/step)',
              BOOL, read_only=True, applies='at start-up', nodes=_SIM),
    ParamSpec('max_spindle_speed', 1500.0, 'rad/s', 'largest accepted spindle/speed_cmd (the '
              'analysis: top of its speed table, > 0)', low=0.0, high=_INF, applies=_AT_STEP,
              nodes=_BOTH),
    ParamSpec('spindle.initial_speed', None, 'rad/s', 'spindle speed at start and after '
              '~/reset; default wbar = 2.7 (P3) with the drive omega0; at most '
              'max_spindle_speed', low=0.0, high=_INF, applies='on ~/reset', nodes=_SIM,
              commands=_RUN),
    ParamSpec('spindle.max_accel', 2000.0, 'rad/s^2', 'spindle motor acceleration limit',
              low=0.0, low_open=True, high=_INF, applies=_AT_STEP, nodes=_SIM, commands=_RUN),
    ParamSpec('spindle.tau', 0.05, 's', 'spindle motor speed-loop time constant', low=0.0,
              low_open=True, high=_INF, applies=_AT_STEP, nodes=_SIM, commands=_RUN),
    ParamSpec('seed', 0, '', 'seed of the IMU noise generator', INTEGER, 0, 2**31 - 1,
              applies='on ~/reset', nodes=_SIM, commands=_RUN),
    # ---- bench: FG speed sensor, faults, disturbances, markers (nodes/bench_settings.py)
    ParamSpec('speed_sensor.pulses_per_rev', 6, '', 'FG pulses per spindle revolution (3 per '
              'pole pair of a BLDC motor)', INTEGER, 1, 1000, applies='on ~/reset', nodes=_SIM),
    ParamSpec('speed_sensor.timer_hz', 1.0e6, 'Hz', 'FG edge capture timer clock '
              '(quantisation)', low=0.0, low_open=True, high=_INF, applies='on ~/reset',
              nodes=_SIM),
    ParamSpec('speed_sensor.edge_jitter', 1.0e-6, 's', 'FG edge time jitter, standard '
              'deviation', low=0.0, high=_INF, applies='on ~/reset', nodes=_SIM),
    ParamSpec('speed_sensor.timeout', 0.1, 's', 'no FG edge for this long reads 0 rad/s: '
              'below 2 pi / (pulses_per_rev timeout), 10.47 rad/s by default, the reading drops '
              'to 0 between edges',
              low=0.0, low_open=True, high=_INF, applies='on ~/reset', nodes=_SIM),
    ParamSpec('speed_sensor.pitch_error', 0.0, 'rad', 'FG pole-pitch error, RMS over the '
              'edges of a revolution: a zero-mean pattern drawn from the seed, repeating every '
              'revolution; below pi / pulses_per_rev^1.5', low=0.0, high=_INF,
              applies='on ~/reset', nodes=_SIM),
    ParamSpec('fault.imu_dropout', False, '', 'IMU dropout: no deck/imu messages while true',
              BOOL, applies=_AT_STEP, nodes=_SIM),
    ParamSpec('fault.imu_stuck', False, '', 'IMU stuck: deck/imu repeats its last reading '
              'while true', BOOL, applies=_AT_STEP, nodes=_SIM),
    ParamSpec('fault.imu_accel_bias_step', [0.0, 0.0, 0.0], 'm/s^2', 'bias step added to '
              'deck/imu specific force, deck axes', DOUBLE_ARRAY, length=3, applies=_AT_STEP,
              nodes=_SIM),
    ParamSpec('fault.imu_gyro_bias_step', [0.0, 0.0, 0.0], 'rad/s', 'bias step added to '
              'deck/imu angular rate, deck axes', DOUBLE_ARRAY, length=3, applies=_AT_STEP,
              nodes=_SIM),
    ParamSpec('fault.speed_dropout', False, '', 'speed sensor dropout: no spindle/speed while '
              'true', BOOL, applies=_AT_STEP, nodes=_SIM),
    ParamSpec('fault.speed_noise', 0.0, 'rad/s', 'white noise added to spindle/speed, std',
              low=0.0, high=_INF, applies=_AT_STEP, nodes=_SIM),
    ParamSpec('disturbance.shock_velocity', [0.0] * 6, 'm/s, rad/s', 'deck twist step of '
              '~/apply_shock, deck axes [vx, vy, vz, wx, wy, wz]', DOUBLE_ARRAY, length=6,
              applies='on ~/apply_shock', nodes=_SIM),
    ParamSpec('disturbance.disc_eps', 0.25e-3, 'm', 'eccentricity eps of the disc put in by '
              '~/swap_disc (becomes drive.eps)', low=0.0, high=1.0, applies='on ~/swap_disc',
              nodes=_SIM),
    ParamSpec('disturbance.disc_angle_deg', 0.0, 'deg', 'imbalance angle of the disc put in '
              'by ~/swap_disc, relative to the current one', low=-360.0, high=360.0,
              applies='on ~/swap_disc', nodes=_SIM),
    ParamSpec('visualization.rate_hz', 20.0, 'Hz', 'visualization/markers rate, simulated '
              'time; 0 = off', low=0.0, high=1000.0, applies=_AT_STEP, nodes=_SIM),
    ParamSpec('visualization.exaggeration', 100.0, '', 'deck displacement and tilt scale '
              'factor in visualization/markers', low=0.0, high=1.0e6, applies=_AT_STEP,
              nodes=_SIM),
    ParamSpec('max_stamp_lag', 0.1, 's', 'largest lag of a stamp behind its schedule (the wall '
              'clock at real_time_factor 1); a later plant drops the excess (counted in slips) '
              'and reports ERROR', low=0.001, high=3600.0, applies=_AT_STEP, nodes=_SIM),
    ParamSpec('realtime_priority', 0, '', 'SCHED_FIFO priority of the integrating thread '
              'while paced (real_time_factor > 0); 0 = the normal scheduler. Needs '
              'CAP_SYS_NICE or an rtprio limit; refused: one warning, normal scheduler',
              INTEGER, 0, 99, applies=_AT_STEP, nodes=_SIM),
    ParamSpec('record.path', '', '', 'bag directory the node records what it publishes to '
              '(must not exist); empty: no recording at start (~/start_recording uses it, or '
              'abb_bag_<date>-<time>)', STRING, applies='at start-up', nodes=_SIM),
    ParamSpec('record.topics', [], '', "other topics recorded into the node's bag, taken from "
              'the middleware as the recorder node takes them (e.g. stability/margin, '
              '/diagnostics, spindle/speed_cmd); a topic this node also publishes is then '
              "recorded from the middleware with the others' messages", STRING_ARRAY,
              applies='at start-up', nodes=_SIM),
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
    ParamSpec('spindle.mode', 'speed', '', 'speed: theta prescribed, spindle/speed_cmd '
              'through the speed loop above; torque: theta free, driven by the motor.* '
              'motor from spindle/current_cmd (docs/torque_mode.md)', STRING,
              choices=('speed', 'torque'), applies=_AT_STEP, nodes=_SIM),
    _motor('torque_constant', 'N m/A', 'K_t; the back-EMF constant K_e = K_t [V s/rad]'),
    _motor('resistance', 'ohm', 'winding resistance R_w'),
    _motor('current_limit', 'A', 'drive current limit I_max (commands beyond it saturate)'),
    _motor('voltage_limit', 'V', 'supply voltage V_s: |R_w i + K_t omega| <= V_s'),
    _motor('viscous_friction', 'N m s', 'bearing viscous friction b_v', low_open=False),
    _motor('coulomb_friction', 'N m', 'bearing Coulomb friction T_c', low_open=False),
    _motor('friction_smoothing', 'rad/s', 'speed omega_c of T_c tanh(omega / omega_c)'),
)
"""The simulator node's own parameters (config/simulator.yaml)."""

_ANA = ('analysis',)
ANALYSIS_SPECS = (
    ParamSpec('simulator_node', 'abb_simulator', '', 'node whose drive.* and max_spindle_speed '
              'are followed (relative names resolve in this node\'s namespace)', STRING,
              read_only=True, applies='at start-up', nodes=_ANA),
    ParamSpec('publish_rate_hz', 50.0, 'Hz', 'largest rate of stability/margin and the status',
              low=0.1, high=1000.0, applies='at once', nodes=_ANA),
    ParamSpec('heartbeat_s', 1.0, 's', 'status republished at least this often', low=0.01,
              high=3600.0, applies='at once', nodes=_ANA),
    ParamSpec('table_points', 300, '', 'speeds in the |lambda|max table over '
              '0..max_spindle_speed', INTEGER, 16, 20000, applies='at once', nodes=_ANA),
)
"""Parameters only the analysis node has."""

_REC = ('recorder',)
RECORDER_SPECS = (
    ParamSpec('topics', ['joint_states', 'deck/pose', 'deck/twist', 'deck/imu',
                         'spindle/speed', 'visualization/markers', 'stability/margin',
                         '/diagnostics', 'spindle/speed_cmd', 'spindle/current_cmd'], '',
              'topics to record (relative names resolve in the node\'s namespace)',
              STRING_ARRAY, applies='at start-up', nodes=_REC),
    ParamSpec('output', '', '', 'bag directory (must not exist); empty: '
              'abb_bag_<date>-<time>', STRING, applies='at start-up', nodes=_REC),
    ParamSpec('chunk_size', 768 * 1024, 'bytes', 'MCAP chunk size; a crash loses at most one '
              'chunk', INTEGER, 256, 1 << 30, applies='at start-up', nodes=_REC),
    ParamSpec('compression', 'zstd', '', 'chunk compression', STRING,
              choices=('zstd', 'lz4', 'none'), applies='at start-up', nodes=_REC),
    ParamSpec('queue_depth', 1000, 'messages', 'subscription queue depth (1 s at 1 kHz)',
              INTEGER, 1, 100000, applies='at start-up', nodes=_REC),
    ParamSpec('discovery_period', 0.5, 's', 'how often the graph is searched for new topics',
              low=0.0, low_open=True, high=_INF, applies='at start-up', nodes=_REC),
)
"""The recorder node's parameters."""

_CTL = ('spin_controller',)
CONTROLLER_SPECS = (
    ParamSpec('target_speed', None, 'rad/s', 'speed to reach and hold; default wbar = 2.7 (P3) '
              'with the drive omega0', low=0.0, high=_INF, applies='at once', nodes=_CTL),
    ParamSpec('acceleration', 500.0, 'rad/s^2', 'run-up acceleration of the reference outside '
              'the unbalanced bands (inside them the drive\'s own limit applies)', low=1e-3,
              high=_INF, applies='at once', nodes=_CTL),
    ParamSpec('kp', 0.0, '', 'proportional gain on the speed error (command correction per '
              'rad/s); 0: trust the drive\'s own speed loop', low=0.0, high=100.0,
              applies='at once', nodes=_CTL),
    ParamSpec('ki', 0.0, '1/s', 'integral gain on the speed error while holding, for a drive '
              'whose speed loop leaves a steady error', low=0.0, high=1000.0, applies='at once',
              nodes=_CTL),
    ParamSpec('mode', 'speed', '', 'command mode: speed (spindle/speed_cmd; kp, ki) or '
              'torque (spindle/current_cmd from the speed loop; loop_bandwidth, motor.*)',
              STRING, choices=('speed', 'torque'), read_only=True, applies='at start-up',
              nodes=_CTL),
    ParamSpec('loop_bandwidth', 60.0, 'rad/s', 'torque mode: crossover of the speed loop '
              '(kp = (J_z + I_r) wc / K_t, ki = kp wc / 4)', low=0.0, low_open=True,
              high=1e4, applies='at once', nodes=_CTL),
    ParamSpec('guard_wbar', 0.1, '', 'distance kept from an unbalanced band, in wbar',
              low=0.0, high=1.0, read_only=True, applies='at start-up', nodes=_CTL),
    ParamSpec('table_points', 300, '', 'speeds in the band table over 0..max_spindle_speed',
              INTEGER, 16, 20000, read_only=True, applies='at start-up', nodes=_CTL),
)
"""The example controller's parameters (spin_controller)."""

SPECS = DRIVE_SPECS + SIMULATOR_SPECS + ANALYSIS_SPECS + RECORDER_SPECS + CONTROLLER_SPECS
"""Every parameter. A name may appear twice for different nodes (publish_rate_hz)."""


def specs_for(node: str) -> dict[str, ParamSpec]:
    """{ROS name: spec} of the parameters ``node`` (one of NODES) declares, in order."""
    return {s.name: s for s in SPECS if node in s.nodes}


def spec_for_command(command: str, name: str) -> ParamSpec | None:
    """The spec ``--set name=...`` of ``abb-sim command`` refers to (drive by SI name)."""
    for s in SPECS:
        if command in s.commands and name in (s.short, s.name):
            return s
    return None


def cli_names(command: str) -> list[str]:
    """The spec names ``abb-sim command --set`` accepts (besides omega and Eq. 39 names)."""
    return [s.short for s in SPECS if command in s.commands]


def imu_config(values: Mapping[str, Any]) -> ImuConfig:
    """ImuConfig from {ROS name: value}; missing ``imu.*`` names take the spec default."""
    specs = specs_for('simulator')

    def get(name):
        return values[name] if name in values else specs[name].default

    return ImuConfig(position=tuple(float(x) for x in get('imu.position')),
                     rate=float(get('imu.rate_hz')), gravity=bool(get('imu.gravity')),
                     **{k: float(get('imu.' + k)) for k in (
                         'accel_noise_density', 'accel_bias', 'accel_bias_random_walk',
                         'gyro_noise_density', 'gyro_bias', 'gyro_bias_random_walk')})


def check_rates(values: Mapping[str, Any]) -> None:
    """The step is a whole number of nanoseconds and the publish and IMU rates divide the
    step rate ({ROS name: value}, missing names take the spec default); raises ParamError."""
    specs = specs_for('simulator')
    rate, publish, imu = (int(values.get(k, specs[k].default)) for k in (
        'integration_rate_hz', 'publish_rate_hz', 'imu.rate_hz'))
    if 1_000_000_000 % rate:
        raise ParamError('integration_rate_hz', rate, 'a divisor of 1e9 (e.g. 10000, 20000, '
                         '40000, 50000)', 'the step must be a whole number of nanoseconds')
    for name, value in (('publish_rate_hz', publish), ('imu.rate_hz', imu)):
        if rate % value:
            raise ParamError(name, value, f'a divisor of integration_rate_hz = {rate}')


def _default_text(spec: ParamSpec) -> str:
    if spec.default is None:
        return '(computed)'
    if isinstance(spec.default, bool):
        return str(spec.default).lower()
    if isinstance(spec.default, str):
        return f"'{spec.default}'"
    if isinstance(spec.default, list):
        return '[' + ', '.join(_default_text(ParamSpec('', x, '', '')) for x in
                               spec.default) + ']'
    return f'{spec.default:g}' if isinstance(spec.default, float) else str(spec.default)


def _table(specs: Iterable[ParamSpec]) -> list[str]:
    rows = ['| name | type | default | valid | applies | `abb-sim --set` | description |',
            '|---|---|---|---|---|---|---|']
    for s in specs:
        applies = s.applies + (' (read-only)' if s.read_only else '')
        cli = ', '.join(s.commands) if s.commands else '-'
        rows.append(f'| `{s.name}` | {s.type} | {_default_text(s)} | {s.valid_text()} | '
                    f'{applies} | {cli} | {s.description.replace("|", chr(92) + "|")} |')
    return rows


def markdown() -> str:
    """docs/parameters.md: one table per node, generated from SPECS."""
    lines = ['# Parameters', '',
             'Generated from `abb_ros/model/param_spec.py` by',
             '`python -m abb_ros.model.param_spec --markdown > docs/parameters.md`;',
             'do not edit by hand (test/test_param_spec.py compares).', '',
             'Ranges: `[` `]` include the bound, `(` `)` exclude it. ROS nodes take the '
             'parameters with `--ros-args -p name:=value` or `--params-file` '
             '(config/cdrom_table1.yaml, config/simulator.yaml); an integer literal for a '
             'double is taken as that double, at start-up and at run time. Invalid values '
             'or types at start-up end the node with exit code 2 and one line naming the '
             'parameter; at run time an invalid value is refused with the same text (a wrong '
             'type with rclpy\'s type error). '
             '`abb-sim` subcommands take the names in the `abb-sim --set` column (drive '
             'parameters without `drive.`), besides `omega` [rad/s] and the Eq. (39) names '
             'wbar, zeta, Dbar, epsbar, mbar.', '']
    titles = {'drive': 'Drive (`drive.*`, simulator, analysis and controller nodes)',
              'simulator': 'Simulator node (`abb_simulator`)',
              'analysis': 'Analysis node (`abb_analysis`)',
              'recorder': 'Recorder node (`abb_recorder`)',
              'controller': 'Example controller (`abb_spin_controller`, executable '
                            '`spin_controller`)'}
    groups = {'drive': DRIVE_SPECS, 'simulator': SIMULATOR_SPECS,
              'analysis': ANALYSIS_SPECS, 'recorder': RECORDER_SPECS,
              'controller': CONTROLLER_SPECS}
    for key, specs in groups.items():
        lines += ['## ' + titles[key], ''] + _table(specs) + ['']
    lines.append('The analysis node and the example controller also declare `drive.*` and '
                 '`max_spindle_speed` (above); the analysis node copies them from the '
                 'simulator it follows; the example controller also declares `motor.*` '
                 '(simulator, above), which must be the simulator\'s in torque mode.')
    return '\n'.join(lines) + '\n'


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv != ['--markdown']:
        print('usage: python -m abb_ros.model.param_spec --markdown', file=sys.stderr)
        return 2
    sys.stdout.write(markdown())
    return 0


if __name__ == '__main__':
    sys.exit(main())

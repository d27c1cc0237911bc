"""Scenario files: parameters, initial conditions and a timed spindle-speed profile.

A scenario is a YAML file (``config/scenarios/<name>.yaml``)::

    name: p3
    description: Point P3 of Fig. 7(b) ...
    drive: {...}            # optional SI drive parameters on top of Table 1
    set: {mbar: 0.03, c: 0.66, wbar: 2.7}   # SI or Eq. (39) names (params.apply_settings)
    initial:                # optional; default Section 5: 0.3 mm, 0 rad, +-60 deg
      deck: [0.3e-3, 0.3e-3, 0.3e-3, 0, 0, 0]    # X, Y, Z [m], alpha, beta, gamma [rad]
      phi_deg: [60, -60]                           # ball angles [deg], one per ball
    duration: 10.0          # [s]
    spindle:                # optional; default constant speed (the paper's case)
      model: motor          # constant | motor
      max_accel: 1000.0     # [rad/s^2] (motor)
      tau: 0.05             # [s] (motor)
      commands:             # timed speed commands, wbar or omega [rad/s]
        - {t: 2.0, wbar: 2.7}

or, with the spindle free and driven by torque (docs/torque_mode.md)::

    spindle:
      model: torque
      motor: {torque_constant: 0.01, current_limit: 1.0}   # optional motor.* names
      commands:             # timed winding-current commands [A] (saturate at the limit)
        - {t: 0.0, current: 0.5}

Errors name the field and what is valid (:class:`~abb_ros.model.parameters.params.ParamError`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from abb_ros.io.files import fields
from abb_ros.io.files.safe_yaml import YamlFileError, load_file
from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.initial import INITIAL_DECK
from abb_ros.model.dynamics.spindle import ConstantSpeed, SpindleMotor, TorqueMotor
from abb_ros.model.parameters.params import PARAM_SPECS, DriveParams, ParamError, apply_settings

__all__ = ['Scenario', 'load_scenario', 'scenario_dir', 'list_scenarios', 'SpeedCommand',
           'CurrentCommand']

_TOP_KEYS = {'name', 'description', 'drive', 'set', 'initial', 'duration', 'spindle'}


@dataclass(frozen=True)
class SpeedCommand:
    """At time t [s], command the spindle speed omega [rad/s]."""

    t: float
    omega: float

    @property
    def value(self) -> float:
        """The command of Simulation.set_command."""
        return self.omega


@dataclass(frozen=True)
class CurrentCommand:
    """At time t [s], command the spindle motor's winding current [A] (torque mode)."""

    t: float
    current: float

    @property
    def value(self) -> float:
        """The command of Simulation.set_command."""
        return self.current


@dataclass
class Scenario:
    """A named run: drive, spindle, start state, duration and commands."""

    name: str
    description: str
    params: DriveParams
    omega: float                     # initial spindle speed [rad/s]
    duration: float                  # [s]
    deck0: tuple = INITIAL_DECK
    phi0: np.ndarray | None = None   # [rad], None: initial.default_phi0
    spindle: object = field(default_factory=ConstantSpeed)
    commands: list = field(default_factory=list)

    def with_settings(self, settings: dict) -> 'Scenario':
        """Return a copy with ``--set`` style settings applied (SI or Eq. 39 names)."""
        params, omega = apply_settings(self.params, settings, self.omega)
        phi0 = self.phi0
        if phi0 is not None and len(phi0) != params.n_balls:
            phi0 = None   # a changed ball count takes the default start (documented)
        return Scenario(self.name, self.description, params, omega, self.duration, self.deck0,
                        phi0, self.spindle, list(self.commands))


def scenario_dir() -> Path:
    """config/scenarios of the checkout, or of the installed share directory."""
    here = Path(__file__).resolve().parents[3] / 'config' / 'scenarios'
    if here.is_dir():
        return here
    try:
        from ament_index_python.packages import get_package_share_directory
        return Path(get_package_share_directory('abb_ros')) / 'config' / 'scenarios'
    except Exception:  # noqa: BLE001 - no ament index: fall back to the checkout path
        return here


def list_scenarios() -> list[str]:
    """Return the names of the shipped scenarios (config/scenarios/*.yaml)."""
    return sorted(p.stem for p in scenario_dir().glob('*.yaml'))


def _numbers(where, value, count, what, **bounds) -> list:
    if not isinstance(value, list) or len(value) != count:
        raise ParamError(where, fields.short(value), f'a list of {count} {what}')
    return [fields.finite_number(f'{where}[{i}]', v, **bounds) for i, v in enumerate(value)]


def _initial_deck(value) -> tuple:
    """Check the start deck state: X, Y, Z within +-MAX_TRANSLATION, angles within +-MAX_ANGLE.

    Outside the envelope of the kernels' state check
    (:func:`abb_ros.model.dynamics.kernels.stepper.check_state`) the small-angle model means
    nothing (it stops at t = 0).
    """
    deck = _numbers('scenario.initial.deck', value, 6, 'numbers X, Y, Z [m], alpha, beta, '
                    'gamma [rad]')
    for i, (name, v) in enumerate(zip(('X', 'Y', 'Z', 'alpha', 'beta', 'gamma'), deck)):
        limit, unit = ((kernels.MAX_TRANSLATION, 'm') if i < 3 else (kernels.MAX_ANGLE, 'rad'))
        fields.finite_number(f'scenario.initial.deck[{i}] ({name})', v, -limit, False, limit, unit)
    return tuple(deck)


def load_scenario(name_or_path: str, base: DriveParams | None = None) -> Scenario:
    """Load a scenario by name (config/scenarios/<name>.yaml) or path.

    It is checked against the schema of this module's docstring: unknown keys at any level,
    wrong types and initial states outside the model's envelope are a :class:`ParamError`
    naming the field.
    """
    path = Path(name_or_path)
    if not (path.suffix in ('.yaml', '.yml') or os.sep in str(name_or_path)):
        path = scenario_dir() / f'{name_or_path}.yaml'
        if not path.exists():
            raise ParamError('scenario', name_or_path,
                             'one of ' + ', '.join(list_scenarios()) + ' or a YAML file')
    try:
        doc = load_file(path)
    except YamlFileError as exc:
        raise ParamError('scenario', str(path), 'a scenario YAML file', exc.why) from None
    if not isinstance(doc, dict):
        raise ParamError('scenario', str(path), 'a mapping with keys ' + ', '.join(
            sorted(_TOP_KEYS)), f'the document is {type(doc).__name__}')
    doc = fields.mapping('scenario', doc, _TOP_KEYS)
    params = base or DriveParams()
    if doc.get('drive') is not None:
        drive = fields.mapping('scenario.drive', doc['drive'], set(PARAM_SPECS))
        params = params.replace(**drive)
    settings = doc.get('set') or {}
    if not isinstance(settings, dict) or not all(isinstance(k, str) for k in settings):
        raise ParamError('scenario.set', fields.short(settings), 'a mapping name: value')
    params, omega = apply_settings(params, settings, None)
    if omega is None:
        omega = 2.7 * params.omega0    # P3's speed, the simulator's default
    duration = fields.finite_number('scenario.duration', doc.get('duration', 10.0), 0.0, True,
                                    unit='s')
    initial = fields.mapping('scenario.initial', doc.get('initial') or {}, {'deck', 'phi_deg'})
    deck0 = _initial_deck(initial['deck']) if 'deck' in initial else INITIAL_DECK
    phi0 = None
    if 'phi_deg' in initial:
        counts = f'n = {params.n}' if not params.race2_n else \
            f"race 1's n = {params.n} then race 2's race2.n = {params.race2_n}"
        phi0 = np.radians(_numbers('scenario.initial.phi_deg', initial['phi_deg'],
                                   params.n_balls, f'ball angles in degrees ({counts})'))
    spindle, commands = _spindle(doc.get('spindle') or {}, params)
    return Scenario(fields.text('scenario.name', doc.get('name', path.stem)),
                    fields.text('scenario.description', doc.get('description', '')), params,
                    float(omega), duration, deck0, phi0, spindle, commands)


def _spindle(spec, params):
    if isinstance(spec, dict) and spec.get('model') == 'torque':
        return _torque_spindle(spec)
    spec = fields.mapping('scenario.spindle', spec, {'model', 'max_accel', 'tau', 'commands'})
    model = spec.get('model', 'constant')
    if model == 'constant':
        extra = sorted(set(spec) - {'model'})
        if extra:
            raise ParamError(f'scenario.spindle.{extra[0]}', '...', 'none with model: constant '
                             '(use model: motor)')
        return ConstantSpeed(), []
    if model != 'motor':
        raise ParamError('scenario.spindle.model', fields.short(model),
                         'constant, motor or torque')
    motor = SpindleMotor(
        max_accel=fields.finite_number('scenario.spindle.max_accel',
                                       spec.get('max_accel', 1000.0), 0, True, unit='rad/s^2'),
        tau=fields.finite_number('scenario.spindle.tau', spec.get('tau', 0.05), 0, True, unit='s'))
    listed = spec.get('commands') or []
    if not isinstance(listed, list):
        raise ParamError('scenario.spindle.commands', fields.short(listed),
                         'a list of {t: seconds, wbar: value} or {t, omega}')
    commands = []
    for i, cmd in enumerate(listed):
        where = f'scenario.spindle.commands[{i}]'
        cmd = fields.mapping(where, cmd, {'t', 'wbar', 'omega'})
        if 't' not in cmd or len({'wbar', 'omega'} & set(cmd)) != 1:
            raise ParamError(where, fields.short(cmd), 'a mapping {t: seconds, wbar: value} or '
                             '{t, omega}')
        t = fields.finite_number(where + '.t', cmd['t'], 0.0, unit='s')
        if 'wbar' in cmd:
            omega = fields.finite_number(where + '.wbar', cmd['wbar'], 0.0) * params.omega0
        else:
            omega = fields.finite_number(where + '.omega', cmd['omega'], 0.0, unit='rad/s')
        commands.append(SpeedCommand(t, omega))
    commands.sort(key=lambda c: c.t)
    return motor, commands


def _torque_spindle(spec):
    """model: torque: a TorqueMotor (motor.* names, MOTOR_DEFAULTS) and timed currents [A]."""
    from abb_ros.model.parameters.plant_spec import MOTOR_DEFAULTS
    spec = fields.mapping('scenario.spindle', spec, {'model', 'motor', 'commands'})
    given = fields.mapping('scenario.spindle.motor', spec.get('motor') or {}, set(MOTOR_DEFAULTS))
    values = {}
    for name, value in given.items():
        low_open = name not in ('viscous_friction', 'coulomb_friction')
        values['motor.' + name] = fields.finite_number(f'scenario.spindle.motor.{name}', value,
                                                       0.0, low_open)
    motor = TorqueMotor.from_values(values)
    listed = spec.get('commands') or []
    if not isinstance(listed, list):
        raise ParamError('scenario.spindle.commands', fields.short(listed),
                         'a list of {t: seconds, current: amperes}')
    commands = []
    for i, cmd in enumerate(listed):
        where = f'scenario.spindle.commands[{i}]'
        cmd = fields.mapping(where, cmd, {'t', 'current'})
        if set(cmd) != {'t', 'current'}:
            raise ParamError(where, fields.short(cmd), 'a mapping {t: seconds, current: amperes}')
        t = fields.finite_number(where + '.t', cmd['t'], 0.0, unit='s')
        current = fields.finite_number(where + '.current', cmd['current'], unit='A')
        commands.append(CurrentCommand(t, current))
    commands.sort(key=lambda c: c.t)
    return motor, commands

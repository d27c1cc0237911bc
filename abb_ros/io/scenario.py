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

Errors name the field and what is valid (:class:`~abb_ros.model.params.ParamError`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from abb_ros.model.integrate import INITIAL_DECK, ConstantSpeed, SpindleMotor
from abb_ros.model.params import DriveParams, ParamError, apply_settings

__all__ = ['Scenario', 'load_scenario', 'scenario_dir', 'list_scenarios', 'SpeedCommand']

_TOP_KEYS = {'name', 'description', 'drive', 'set', 'initial', 'duration', 'spindle'}


@dataclass(frozen=True)
class SpeedCommand:
    """At time t [s], command the spindle speed omega [rad/s]."""

    t: float
    omega: float


@dataclass
class Scenario:
    name: str
    description: str
    params: DriveParams
    omega: float                     # initial spindle speed [rad/s]
    duration: float                  # [s]
    deck0: tuple = INITIAL_DECK
    phi0: np.ndarray | None = None   # [rad], None: integrate.default_phi0
    spindle: object = field(default_factory=ConstantSpeed)
    commands: list = field(default_factory=list)

    def with_settings(self, settings: dict) -> 'Scenario':
        """A copy with ``--set`` style settings applied (SI or Eq. 39 names)."""
        params, omega = apply_settings(self.params, settings, self.omega)
        phi0 = self.phi0
        if phi0 is not None and len(phi0) != params.n:
            phi0 = None   # a changed ball count takes the default start (documented)
        return Scenario(self.name, self.description, params, omega, self.duration, self.deck0,
                        phi0, self.spindle, list(self.commands))


def scenario_dir() -> Path:
    """config/scenarios of the checkout, or of the installed share directory."""
    here = Path(__file__).resolve().parents[2] / 'config' / 'scenarios'
    if here.is_dir():
        return here
    try:
        from ament_index_python.packages import get_package_share_directory
        return Path(get_package_share_directory('abb_ros')) / 'config' / 'scenarios'
    except Exception:  # noqa: BLE001 - no ament index: fall back to the checkout path
        return here


def list_scenarios() -> list[str]:
    return sorted(p.stem for p in scenario_dir().glob('*.yaml'))


def _number(where, value, low=-math.inf, low_open=False):
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if ok:
        ok = value > low if low_open else value >= low
    if not ok:
        rng = f"({low:g}, inf)" if low_open else f"[{low:g}, inf)"
        raise ParamError(where, value, 'a finite number in ' + rng)
    return float(value)


def load_scenario(name_or_path: str, base: DriveParams | None = None) -> Scenario:
    """Load a scenario by name (config/scenarios/<name>.yaml) or path."""
    import yaml
    path = Path(name_or_path)
    if not (path.suffix in ('.yaml', '.yml') or os.sep in str(name_or_path)):
        path = scenario_dir() / f'{name_or_path}.yaml'
        if not path.exists():
            raise ParamError('scenario', name_or_path,
                             'one of ' + ', '.join(list_scenarios()) + ' or a YAML file')
    if not path.exists():
        raise ParamError('scenario', str(path), 'an existing YAML file', 'no such file')
    try:
        with open(path, encoding='utf-8') as f:
            doc = yaml.safe_load(f)
    except yaml.YAMLError as exc:
        raise ParamError('scenario', str(path), 'a valid YAML file', f'malformed: {exc}') from None
    if not isinstance(doc, dict):
        raise ParamError('scenario', str(path),
                         'a YAML mapping of ' + ', '.join(sorted(_TOP_KEYS)))
    unknown = set(doc) - _TOP_KEYS
    if unknown:
        raise ParamError(f'scenario.{sorted(unknown)[0]}', '...',
                         'known keys: ' + ', '.join(sorted(_TOP_KEYS)), 'unknown key')
    params = base or DriveParams()
    if doc.get('drive'):
        if not isinstance(doc['drive'], dict):
            raise ParamError('scenario.drive', doc['drive'], 'a mapping of SI parameters')
        params = params.replace(**doc['drive'])
    settings = doc.get('set') or {}
    if not isinstance(settings, dict):
        raise ParamError('scenario.set', settings, 'a mapping name: value')
    params, omega = apply_settings(params, settings, None)
    if omega is None:
        omega = 2.7 * params.omega0    # P3's speed, the simulator's default
    duration = _number('scenario.duration', doc.get('duration', 10.0), 0.0, low_open=True)
    initial = doc.get('initial') or {}
    deck0 = tuple(initial.get('deck', INITIAL_DECK))
    if len(deck0) != 6:
        raise ParamError('scenario.initial.deck', list(deck0), '6 numbers X, Y, Z, alpha, beta, '
                         'gamma')
    deck0 = tuple(_number('scenario.initial.deck', v) for v in deck0)
    phi0 = None
    if 'phi_deg' in initial:
        phi_deg = initial['phi_deg']
        if not isinstance(phi_deg, list) or len(phi_deg) != params.n:
            raise ParamError('scenario.initial.phi_deg', phi_deg, f'a list of n = {params.n} '
                             'angles in degrees')
        phi0 = np.radians([_number('scenario.initial.phi_deg', v) for v in phi_deg])
    spindle, commands = _spindle(doc.get('spindle') or {}, params)
    return Scenario(str(doc.get('name', path.stem)), str(doc.get('description', '')), params,
                    float(omega), duration, deck0, phi0, spindle, commands)


def _spindle(spec, params):
    if not isinstance(spec, dict):
        raise ParamError('scenario.spindle', spec, 'a mapping with model: constant | motor')
    model = spec.get('model', 'constant')
    if model == 'constant':
        if spec.get('commands'):
            raise ParamError('scenario.spindle.commands', '...', 'none with model: constant '
                             '(use model: motor)')
        return ConstantSpeed(), []
    if model != 'motor':
        raise ParamError('scenario.spindle.model', model, 'constant or motor')
    motor = SpindleMotor(
        max_accel=_number('scenario.spindle.max_accel', spec.get('max_accel', 1000.0), 0, True),
        tau=_number('scenario.spindle.tau', spec.get('tau', 0.05), 0, True))
    commands = []
    for i, cmd in enumerate(spec.get('commands') or []):
        where = f'scenario.spindle.commands[{i}]'
        if not isinstance(cmd, dict) or 't' not in cmd or not ({'wbar', 'omega'} & set(cmd)):
            raise ParamError(where, cmd, 'a mapping {t: seconds, wbar: value} or {t, omega}')
        t = _number(where + '.t', cmd['t'], 0.0)
        if 'wbar' in cmd:
            omega = _number(where + '.wbar', cmd['wbar'], 0.0) * params.omega0
        else:
            omega = _number(where + '.omega', cmd['omega'], 0.0)
        commands.append(SpeedCommand(t, omega))
    commands.sort(key=lambda c: c.t)
    return motor, commands

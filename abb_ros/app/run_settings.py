"""What ``abb-sim run`` asks of a headless run: its settings applied, and its summary.

:func:`apply_settings` splits the ``--set`` values into the drive's (applied to the scenario)
and the simulator node's that apply headless (rates, spindle, seed, IMU: keyword arguments of
:func:`abb_ros.app.headless.run_scenario`); :func:`summary` is the run's result as the command
prints it. No file is touched and nothing of the command line is needed, so a test calls them
directly.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from abb_ros.model.dynamics.spindle import SpindleMotor, TorqueMotor
from abb_ros.model.dynamics.state import StateLayout, wrap_degrees
from abb_ros.model.parameters.params import DIMENSIONLESS_NAMES, PARAM_SPECS, ParamError
from abb_ros.model.parameters.plant_spec import PLANT, check_rates, imu_config, step_of

__all__ = ['DRIVE_SETTINGS', 'apply_settings', 'run_options', 'spindle_with', 'summary']

DRIVE_SETTINGS = ('omega',) + DIMENSIONLESS_NAMES + tuple(PARAM_SPECS)
"""--set names that go to the scenario's drive (the others are node parameters)."""


def apply_settings(scenario, settings: dict):
    """Apply ``--set`` values (parsed and checked one by one) to ``scenario``.

    Returns
    -------
    scenario : abb_ros.io.files.scenario.Scenario
        The scenario with the drive's settings and the spindle's applied.
    options : dict
        :func:`run_options` of the node parameters among the settings.
    """
    settings = dict(settings)
    node = {k: settings.pop(k) for k in list(settings) if k not in DRIVE_SETTINGS}
    if 'spindle.initial_speed' in node:
        settings['omega'] = node.pop('spindle.initial_speed')
    if settings:
        scenario = scenario.with_settings(settings)
    scenario.spindle = spindle_with(scenario.spindle, node)
    return scenario, run_options(node)


def run_options(node: dict) -> dict:
    """Return run_scenario's keyword arguments for the node parameters given with --set.

    Returns
    -------
    dict
        ``dt``, ``publish_dt``, ``imu_config``, ``seed``: those the parameters set.
    """
    check_rates(node)
    options = {}
    if 'integration_rate_hz' in node:
        options['dt'] = step_of(node['integration_rate_hz'])[1]
    if 'publish_rate_hz' in node:
        options['publish_dt'] = 1.0 / node['publish_rate_hz']
    if any(k.startswith('imu.') for k in node):
        options['imu_config'] = imu_config(node)
    if 'seed' in node:
        options['seed'] = node['seed']
    return options


def spindle_with(spindle, node: dict):
    """Return ``spindle`` with spindle.max_accel / spindle.tau of ``node`` applied.

    A constant-speed spindle becomes the motor of the simulator node, with its defaults for
    the other; a torque-driven one takes neither (ParamError).

    Returns
    -------
    spindle
        The spindle to run with (``spindle`` itself when ``node`` changes nothing).
    """
    changes = {k[len('spindle.'):]: v for k, v in node.items() if k.startswith('spindle.')}
    if not changes:
        return spindle
    if isinstance(spindle, TorqueMotor):
        name = sorted(changes)[0]
        raise ParamError(f'spindle.{name}', changes[name], 'none: the scenario drives the '
                         'spindle by torque (spindle: model: torque)')
    if not isinstance(spindle, SpindleMotor):
        spindle = SpindleMotor(PLANT['spindle.max_accel'].default, PLANT['spindle.tau'].default)
    return dataclasses.replace(spindle, **changes)


TILT_FIT_PERIODS = 4
"""Spindle periods at the end of a run whose samples the residual tilt is fitted to."""
TILT_FIT_MIN_SAMPLES = 4 * 5
"""Fewest samples the fit takes: four per coefficient of harmonics 0-2 (five)."""


def residual_tilt(t, ys, layout: StateLayout, omega: float) -> float:
    """Return the final residual tilt amplitude [rad]: max sqrt(alpha^2 + beta^2) over a period.

    What the balls leave of a couple they cannot cancel (P, G or the race off the washers'
    plane, docs/equations.md F4). The tilt's orbit is an ellipse that a few samples per period
    (1 kHz against 130 rev/s) cut short by several per cent, so alpha and beta over the last
    :data:`TILT_FIT_PERIODS` periods are fitted (least squares) with harmonics 0-2 of the
    rotor angle theta, and the maximum is taken over one period of the fit. With fewer samples
    than that needs, or the spindle standing, it is the largest sampled value.
    """
    last = t >= t[-1] - TILT_FIT_PERIODS * 2.0 * math.pi / omega if omega > 0 else t >= t[-1]
    deck = ys[last][:, layout.deck_slice]
    tilt = deck[:, 3:5]
    if tilt.shape[0] < TILT_FIT_MIN_SAMPLES:
        return float(np.max(np.hypot(tilt[:, 0], tilt[:, 1])))
    from abb_ros.model.stability.linear import harmonic_basis  # scipy: only when fitting
    theta = ys[last][:, layout.theta_index]
    coef = np.linalg.lstsq(harmonic_basis(theta, 2), tilt, rcond=None)[0]
    fit = harmonic_basis(np.linspace(0.0, 2.0 * math.pi, 721), 2) @ coef
    return float(np.max(np.hypot(fit[:, 0], fit[:, 1])))


def summary(scenario, result) -> dict:
    """Return the summary of a finished run: where the drive ended, and what it cost.

    Returns
    -------
    dict
        Speed, final rbar, residual tilt and ball angles, times; the terms beyond the paper
        and the contact and rolling statistics when there are any.
    """
    p = scenario.params
    y = result.y[-1]
    layout = StateLayout(p.n_balls)
    omega = float(layout.omega(y))
    out = {
        'scenario': scenario.name,
        'n': p.n,
        **({'race2_n': p.race2_n} if p.race2_n else {}),
        'wbar': omega / p.omega0,
        'omega_rad_s': omega,
        'duration_s': float(result.t[-1] - result.t[0]),
        'final_rbar': float(layout.rbar(y, p.R)),
        'tilt_rad': residual_tilt(result.t, result.y, layout, omega),
        'ball_angles_deg': [round(float(a), 3) for a in wrap_degrees(layout.phi(y))],
        'wall_time_s': round(result.wall_time, 4),
        'real_time_factor': round(result.real_time_factor, 2),
        'compile_time_s': round(result.compile_time, 3),
        'integrator': result.integrator,
    }
    if result.integrator_note:
        out['integrator_note'] = result.integrator_note
    if p.beyond_paper:
        out['beyond_paper'] = list(p.beyond_paper)
    if result.contact_step_note:
        out['contact_step_note'] = result.contact_step_note
    if result.refined_steps:
        out['contact_refined_steps'] = result.refined_steps
        out['contact_max_substeps'] = result.max_substeps
    if result.rolling_switches:
        out['rolling_switches'] = result.rolling_switches
    return out

"""What a subcommand reads: `--set` items, a `--config` drive file, `--scenario` with them."""

from __future__ import annotations

from abb_ros.commands.settings import cli_names, spec_for_command
from abb_ros.commands.shared.errors import UsageError
from abb_ros.io.files.drive_file import read_drive_yaml
from abb_ros.io.files.safe_yaml import YamlFileError, load_text
from abb_ros.model.parameters.param_spec import STRING, ParamError, ParamSpec
from abb_ros.model.parameters.params import (
    DIMENSIONLESS_NAMES,
    PARAM_SPECS,
    DriveParams,
    parse_value,
)


def parse_settings(items, command: str | None = None) -> dict:
    """``['k=4000', 'wbar=2.7']`` -> ``{'k': 4000.0, 'wbar': 2.7}``.

    Drive (SI and Eq. 39) values are checked later, together; with ``command`` the other
    names it accepts (:mod:`abb_ros.commands.settings`, e.g. ``imu.*`` for run) are parsed
    and checked here, and an unknown name is an error listing the valid ones.
    """
    settings = {}
    for item in items or []:
        if '=' not in item:
            raise UsageError(f'--set expects key=value, got {item!r}')
        key, text = item.split('=', 1)
        key = key.strip()
        spec = spec_for_command(command, key) if command else None
        if key in PARAM_SPECS or spec is None:
            if command and key not in ('omega',) + DIMENSIONLESS_NAMES + tuple(PARAM_SPECS):
                valid = ', '.join(cli_names(command) + ['omega', *DIMENSIONLESS_NAMES])
                raise ParamError(key, text, 'a known name: ' + valid, 'unknown parameter')
            settings[key] = parse_value(key, text.strip())
        else:
            settings[key] = parse_spec_value(spec, text.strip(), key)
    return settings


def parse_spec_value(spec: ParamSpec, text: str, name: str):
    """Return the value of ``--set name=text`` (YAML syntax, as ``ros2 param set``), checked.

    A string parameter takes ``text`` as it is; raises ParamError naming ``name``.
    """
    try:
        value = load_text(text, where=name)
    except YamlFileError:
        value = text
    if spec.type == STRING:
        value = text
    return spec.check(value, name)


def drive_params(config) -> DriveParams:
    """Read the drive parameters of the ``--config`` parameter file.

    Table 1 without one; an error names the file.
    """
    if not config:
        return DriveParams()
    try:
        return read_drive_yaml(config)
    except ParamError as exc:
        if exc.name == 'config':
            raise
        raise UsageError(f'--config {config}: {exc}') from None


def run_scenario_from_args(name: str, config, set_items, no_abb: bool = False,
                           duration: float | None = None):
    """Return the scenario of ``--scenario``/``--config``/``--set`` and run_scenario's options.

    As ``abb-sim run`` takes them: drive settings (SI, Eq. 39, omega) change the scenario's
    drive, ``spindle.*`` its spindle, the node parameters that apply headless its options
    (``dt``, ``publish_dt``, ``imu_config``, ``seed``); ``duration`` [s] (None: the
    scenario's) replaces its duration. Errors are one line naming the option.
    """
    import math

    from abb_ros.app.headless import PUBLISH_DT, check_duration
    from abb_ros.app.run_settings import apply_settings
    from abb_ros.io.files.scenario import load_scenario
    base = drive_params(config) if config else None
    try:
        scenario = load_scenario(name, base=base)
    except ParamError as exc:
        if exc.name == 'scenario':     # names the file already
            raise
        raise UsageError(f'--scenario {name}: {exc}') from None
    settings = parse_settings(set_items, 'run')
    if no_abb:
        settings['n'] = 0
    scenario, options = apply_settings(scenario, settings)   # checked before any file is made
    if duration is not None:
        if not (math.isfinite(duration) and duration > 0):
            raise ParamError('duration', duration, '(0, inf) s')
        scenario.duration = float(duration)
    try:
        check_duration(scenario.duration, options.get('publish_dt', PUBLISH_DT), options.get('dt'))
    except ParamError as exc:
        if duration is not None:
            raise
        raise UsageError(f'--scenario {name}: {exc}') from None
    return scenario, options

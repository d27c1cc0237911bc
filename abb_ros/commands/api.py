"""What the `abb-sim` subcommands share, importable without the dispatcher (abb_ros/cli.py).

As ros2cli keeps its helpers in ``api`` modules: a subcommand imports from here, and the
dispatcher imports the subcommands; nothing imports the dispatcher.
"""

from __future__ import annotations

from abb_ros.model.param_spec import ParamError, cli_names, spec_for_command
from abb_ros.model.params import DIMENSIONLESS_NAMES, PARAM_SPECS, parse_value

__all__ = ['UsageError', 'parse_settings']


class UsageError(Exception):
    """Bad command-line input that is not a single parameter (exit code 2)."""


def parse_settings(items, command: str | None = None) -> dict:
    """``['k=4000', 'wbar=2.7']`` -> ``{'k': 4000.0, 'wbar': 2.7}``.

    Drive (SI and Eq. 39) values are checked later, together; with ``command`` the other
    names it accepts (abb_ros/model/param_spec.py, e.g. ``imu.*`` for run) are parsed and
    checked here, and an unknown name is an error listing the valid ones."""
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
            settings[key] = spec.parse(text.strip(), key)
    return settings

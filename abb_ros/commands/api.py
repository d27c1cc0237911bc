"""What the `abb-sim` subcommands share, importable without the dispatcher (abb_ros/cli.py).

As ros2cli keeps its helpers in ``api`` modules: a subcommand imports from here, and the
dispatcher imports the subcommands; nothing imports the dispatcher.
"""

from __future__ import annotations

from abb_ros.model.params import parse_value

__all__ = ['UsageError', 'parse_settings']


class UsageError(Exception):
    """Bad command-line input that is not a single parameter (exit code 2)."""


def parse_settings(items) -> dict:
    """``['k=4000', 'wbar=2.7']`` -> ``{'k': 4000.0, 'wbar': 2.7}`` (values checked later)."""
    settings = {}
    for item in items or []:
        if '=' not in item:
            raise UsageError(f'--set expects key=value, got {item!r}')
        key, text = item.split('=', 1)
        key = key.strip()
        settings[key] = parse_value(key, text.strip())
    return settings

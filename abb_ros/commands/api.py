"""What the `abb-sim` subcommands share, importable without the dispatcher (abb_ros/cli.py).

As ros2cli keeps its helpers in ``api`` modules: a subcommand imports from here, and the
dispatcher imports the subcommands; nothing imports the dispatcher.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
from pathlib import Path

from abb_ros.io.drive_file import read_drive_yaml
from abb_ros.io.safe_yaml import YamlFileError, load_text
from abb_ros.model.parameters.param_spec import STRING, ParamError, ParamSpec
from abb_ros.model.parameters.params import (
    DIMENSIONLESS_NAMES,
    PARAM_SPECS,
    DriveParams,
    parse_value,
)
from abb_ros.model.parameters.plant_spec import cli_names, spec_for_command

__all__ = ['UsageError', 'CommandFailed', 'Terminated', 'stop_signals', 'signals_deferred',
           'stop_point',
           'parse_settings', 'parse_spec_value', 'drive_params', 'check_output', 'output_files',
           'stage_directory', 'commit_directory']


class UsageError(Exception):
    """Bad command-line input that is not a single parameter (exit code 2)."""


class CommandFailed(Exception):
    """The input was good but the command could not finish, e.g. a full disk (exit code 1)."""


class Terminated(BaseException):
    """SIGTERM arrived (exit code 143): like KeyboardInterrupt, it unwinds every ``finally``."""


_DEFERRED = {'depth': 0, 'pending': None}


def _on_signal(signum, frame):
    if _DEFERRED['depth']:
        _DEFERRED['pending'] = signum
        return
    raise KeyboardInterrupt if signum == signal.SIGINT else Terminated(signum)


@contextlib.contextmanager
def stop_signals():
    """Turn SIGINT into KeyboardInterrupt and SIGTERM into :class:`Terminated` while inside.

    The previous handlers come back on exit (``abb_ros.cli.main`` runs in-process in tests).
    """
    previous = {s: signal.signal(s, _on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


@contextlib.contextmanager
def signals_deferred():
    """Hold SIGINT and SIGTERM until the block is done (finishing a file must not be cut)."""
    _DEFERRED['depth'] += 1
    try:
        yield
    finally:
        _DEFERRED['depth'] -= 1
        pending, _DEFERRED['pending'] = _DEFERRED['pending'], None
        if pending is not None and not _DEFERRED['depth']:
            _on_signal(pending, None)


def stop_point(progress=None):
    """Return a progress callback that first raises a signal held by :func:`signals_deferred`.

    Work run with signals held and this callback stops between two of its chunks only, never
    in the middle of writing a message.
    """
    def report(done):
        pending, _DEFERRED['pending'] = _DEFERRED['pending'], None
        if pending is not None:
            raise KeyboardInterrupt if pending == signal.SIGINT else Terminated(pending)
        if progress is not None:
            progress(done)
    return report


def parse_settings(items, command: str | None = None) -> dict:
    """``['k=4000', 'wbar=2.7']`` -> ``{'k': 4000.0, 'wbar': 2.7}``.

    Drive (SI and Eq. 39) values are checked later, together; with ``command`` the other
    names it accepts (abb_ros/model/parameters/plant_spec.py, e.g. ``imu.*`` for run) are parsed
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


def check_output(option: str, path, suffixes=None) -> Path:
    """Refuse, before any work, an output path whose folder cannot take it."""
    path = Path(path)
    if suffixes is not None and path.suffix not in suffixes:
        raise UsageError(f'{option} {path}: the name must end in one of '
                         f'{", ".join(sorted(suffixes))}')
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise UsageError(f'{option} {path}: {parent} is not a directory')
    if not os.access(parent, os.W_OK | os.X_OK):
        raise UsageError(f'{option} {path}: {parent} is not writable')
    return path


@contextlib.contextmanager
def output_files(*paths):
    """Yield temporary names beside ``paths`` (same suffix).

    On success they replace the paths together, on any error they are removed, so no
    partial file is left behind.
    """
    paths = [Path(p) for p in paths]
    temps = [p.with_name(f'.{p.stem}.partial{p.suffix}') for p in paths]
    try:
        for p in paths:
            p.parent.mkdir(parents=True, exist_ok=True)
        yield temps
        for tmp, final in zip(temps, paths):
            os.replace(tmp, final)
    except BaseException:
        for tmp in temps:
            with contextlib.suppress(OSError):
                tmp.unlink()
        raise


def _one_bag(path: Path) -> str:
    """Return why the directory ``path`` is not one bag (a metadata.yaml, its .mcap files)."""
    if not path.is_dir() or path.is_symlink():
        return 'it is not a directory'
    names = sorted(p.name for p in path.iterdir())
    mcaps = [n for n in names if n.endswith('.mcap')]
    others = [n for n in names if n not in mcaps and n != 'metadata.yaml']
    if others:
        return f'it holds {others[0]}, which is not part of a bag'
    if 'metadata.yaml' not in names and mcaps:
        return f'it holds {len(mcaps)} recording(s) without a metadata.yaml'
    if len(mcaps) > 1:
        return f'it holds {len(mcaps)} recordings'
    return ''


def stage_directory(option: str, path, overwrite: bool) -> Path:
    """Return where to write the directory ``path`` (a bag), refusing to replace one silently.

    A new ``path`` is returned as it is. An existing one is refused (UsageError naming
    ``option``) unless ``overwrite`` is given and it is one bag; then the new directory is
    written in a hidden directory beside it, which :func:`commit_directory` moves into place,
    so the old bag stays whole until the new one is there.
    """
    path = Path(path)
    if not (path.exists() or path.is_symlink()):
        return path
    if not overwrite:
        raise UsageError(f'{option} {path}: it exists; pass --overwrite to replace it')
    why = _one_bag(path)
    if why:
        raise UsageError(f'{option} {path}: {why}; not replacing it (--overwrite replaces one '
                         'bag directory only)')
    staging = path.with_name(f'.{path.name}.partial')
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir()
    return staging / path.name


def commit_directory(path, staged) -> None:
    """Move ``staged`` (of :func:`stage_directory`) onto ``path`` if it was kept; tidy up."""
    path, staged = Path(path), Path(staged)
    if staged == path:
        return
    with signals_deferred():
        if staged.exists():
            old = path.with_name(f'.{path.name}.old')
            shutil.rmtree(old, ignore_errors=True)
            os.replace(path, old)
            os.replace(staged, path)
            shutil.rmtree(old, ignore_errors=True)
        shutil.rmtree(staged.parent, ignore_errors=True)

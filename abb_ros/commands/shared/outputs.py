"""What a subcommand writes: output paths checked first, files and bag directories moved whole."""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
from pathlib import Path

from abb_ros.commands.shared.errors import UsageError
from abb_ros.commands.shared.signals import signals_deferred
from abb_ros.io.files.safe_yaml import YamlFileError, load_file


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


def writable_directory(option: str, path) -> Path:
    """Make the output directory ``path`` (and its parents) now, before any work.

    A directory the system refuses (read-only file system, no permission, ``/sys``...) is a
    UsageError naming ``option`` (exit code 2: bad input), never an OSError after the work.
    """
    import tempfile
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
        if not os.access(path, os.W_OK | os.X_OK):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        raise UsageError(f'{option} {path}: cannot be written ({exc.strerror or exc}); give a '
                         'directory this user may create and write') from None
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
    return _written_here(path / 'metadata.yaml')


def _written_here(metadata: Path) -> str:
    """Return why ``metadata`` is not that of a bag abb_ros wrote ('' if it is).

    Its ``custom_data`` names this package's writer (``abb_ros.writer``; bags of earlier
    versions: their ``abb_ros.drive_params``). A user's folder that merely holds a
    ``metadata.yaml`` and an ``.mcap`` is not replaced.
    """
    from abb_ros.io.bag.writer import DRIVE_METADATA, WRITER_KEY  # mcap: not for --help
    try:
        info = (load_file(metadata) or {}).get('rosbag2_bagfile_information') or {}
        custom = info.get('custom_data') or {}
    except (YamlFileError, AttributeError):
        return 'its metadata.yaml is not that of a rosbag2 bag'
    if not isinstance(custom, dict) or not (WRITER_KEY in custom
                                            or f'{DRIVE_METADATA}.drive_params' in custom):
        return (f'its metadata.yaml does not say abb_ros wrote it (custom_data '
                f'{WRITER_KEY})')
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

"""What the `abb-sim` subcommands share, importable without the dispatcher (abb_ros/cli.py).

As ros2cli keeps its helpers in ``api`` modules: a subcommand imports from here, and the
dispatcher imports the subcommands; nothing imports the dispatcher.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import signal
from pathlib import Path

from abb_ros.commands.settings import cli_names, spec_for_command
from abb_ros.io.files.drive_file import read_drive_yaml
from abb_ros.io.files.safe_yaml import YamlFileError, load_file, load_text
from abb_ros.model.parameters.param_spec import STRING, ParamError, ParamSpec
from abb_ros.model.parameters.params import (
    DIMENSIONLESS_NAMES,
    PARAM_SPECS,
    DriveParams,
    parse_value,
)

__all__ = ['UsageError', 'CommandFailed', 'Terminated', 'stop_signals', 'signals_deferred',
           'stop_point',
           'parse_settings', 'parse_spec_value', 'drive_params', 'check_output', 'output_files',
           'stage_directory', 'commit_directory', 'writable_directory', 'run_scenario_from_args',
           'dask_client', 'add_dask_arguments', 'check_dask_options']



class UsageError(Exception):
    """Bad command-line input that is not a single parameter (exit code 2)."""


class CommandFailed(Exception):
    """The input was good but the command could not finish, e.g. a full disk (exit code 1)."""


class Terminated(BaseException):
    """SIGTERM arrived (exit code 143): like KeyboardInterrupt, it unwinds every ``finally``."""


_DEFERRED = {'depth': 0, 'pending': None}


_CALLBACK_FILES = ('weakref.py', '_weakrefset.py')


def _in_finalizer(frame) -> bool:
    """Whether ``frame`` is a weakref callback or a ``__del__`` (or called from one).

    An exception raised there is printed as "Exception ignored in ..." with a traceback and
    then dropped: the signal would be lost.
    """
    for _ in range(3):
        if frame is None:
            return False
        code = frame.f_code
        if code.co_name == '__del__' or code.co_filename.endswith(_CALLBACK_FILES):
            return True
        frame = frame.f_back
    return False


def _on_signal(signum, frame):
    if _DEFERRED['depth']:
        _DEFERRED['pending'] = signum
        return
    if _in_finalizer(frame):   # the same signal again in a moment, outside the finalizer
        import threading
        threading.Timer(0.01, os.kill, (os.getpid(), signum)).start()
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


def add_dask_arguments(parser, work: str) -> None:
    """Add the options of a command that computes partitions on Dask (sweep, basin).

    ``work`` names what ``--resume`` finishes (e.g. 'sweep', 'study').
    """
    parser.add_argument('--workers', type=int, default=None,
                        help='worker processes of the local cluster (default: CPU count)')
    parser.add_argument('--scheduler', help='address of a running Dask scheduler, '
                        'tcp://HOST:PORT (default: start a local cluster)')
    parser.add_argument('--resume', action='store_true',
                        help=f'finish the {work} in --out: compute only the missing partitions')
    parser.add_argument('--serial', action='store_true',
                        help='no Dask: compute the partitions in this process, in order')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')


def check_dask_options(scheduler=None, workers=None, serial: bool = False) -> None:
    """Refuse ``--scheduler``, ``--workers`` and ``--serial`` that contradict each other."""
    if workers is not None and scheduler:
        raise UsageError('--workers applies to the local cluster only; leave it out with '
                         '--scheduler')
    if serial and (scheduler or workers is not None):
        raise UsageError('--serial runs in this process: leave out --scheduler and --workers')
    if workers is not None and not 1 <= workers <= 256:
        raise UsageError(f'--workers {workers}: valid range is 1..256')


@contextlib.contextmanager
def dask_client(command: str, scheduler=None, workers=None, serial: bool = False):
    """Yield a distributed.Client (None with ``serial``), closed (and its cluster) at the end.

    ``scheduler`` tcp://HOST:PORT connects to a running cluster; otherwise a LocalCluster of
    ``workers`` processes (default the CPU count) is started on 127.0.0.1. The options are
    checked first (:func:`check_dask_options`).
    """
    import sys
    check_dask_options(scheduler, workers, serial)
    if serial:
        yield None
        return
    from distributed import Client

    from abb_ros.sweep.runner import has_bokeh, local_cluster
    cluster = client = None
    stack = contextlib.ExitStack()
    try:
        if scheduler:
            try:
                client = Client(scheduler, timeout='20s')
            except (OSError, TimeoutError, ValueError) as exc:
                raise UsageError(f'--scheduler {scheduler}: cannot connect ({exc})') from None
        else:
            # a signal while the cluster starts is held until it stands, then unwinds through
            # the finally below, which closes it (never a half-made cluster that
            # distributed's atexit hook trips over)
            with signals_deferred():
                stack.enter_context(_workers_deaf_to_sigint())   # restarts too, till the end
                cluster = local_cluster(workers or os.cpu_count() or 1, dashboard=True)
                client = Client(cluster)
        if has_bokeh() and _has_dashboard(client):
            print(f'abb-sim {command}: Dask dashboard at {client.dashboard_link}',
                  file=sys.stderr)
        yield client
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
        stack.close()


@contextlib.contextmanager
def _workers_deaf_to_sigint():
    """Start the local cluster's workers with SIGINT ignored; only this process takes it.

    A Ctrl-C at the terminal signals the whole process group: each Dask worker process would
    print a KeyboardInterrupt traceback (thirty lines each) while this process stops the
    cluster anyway. An ignored signal stays ignored across fork and exec, and Python then
    installs no handler of its own, so the workers are forked from a forkserver started
    with SIGINT ignored (for a few milliseconds here: its start, not the cluster's; the
    forkserver also makes each worker start faster, with distributed preloaded).
    """
    import multiprocessing.forkserver

    import dask
    from distributed.utils import get_mp_context
    with dask.config.set({'distributed.worker.multiprocessing-method': 'forkserver'}):
        get_mp_context()   # the forkserver's preload (distributed and its packages)
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            multiprocessing.forkserver.ensure_running()
        finally:
            signal.signal(signal.SIGINT, previous)
        yield


def run_on_dask(command: str, args, total: int, unit: str, desc: str, work):
    """Run ``work(client, progress)`` on the Dask client of ``args``' options, with a bar.

    ``args``: the command's parsed options (``scheduler``, ``workers``, ``serial``,
    ``no_progress``). The bar (tqdm, on stderr) counts ``total`` ``unit``s. A SweepError or
    SweepFileError of ``work`` is a usage error. Returns (what ``work`` returned, the number
    of workers).
    """
    import sys

    from abb_ros.sweep.runner import SweepError
    from abb_ros.sweep.store import SweepFileError
    bar = None
    if not args.no_progress:
        from tqdm import tqdm
        bar = tqdm(total=total, unit=unit, file=sys.stderr, desc=desc, smoothing=0.1)
    try:
        with dask_client(command, args.scheduler, args.workers, args.serial) as client:
            try:
                result = work(client, bar.update if bar else None)
            except (SweepError, SweepFileError) as exc:   # the directory, not the cluster
                raise UsageError(str(exc)) from None
            workers = len(client.scheduler_info()['workers']) if client is not None else 0
    finally:
        if bar is not None:
            bar.close()
    return result, workers


def _has_dashboard(client) -> bool:
    """Return whether the scheduler serves the Dask dashboard.

    A scheduler serves the dashboard on its HTTP server only with bokeh installed; for a
    remote scheduler this machine's bokeh is the best guess there is.
    """
    try:
        return 'dashboard' in client.scheduler_info().get('services', {})
    except Exception:  # noqa: BLE001 - an old scheduler without the field: say nothing
        return False

"""The Dask cluster of the commands that compute partitions (sweep, basin), with a progress bar."""

from __future__ import annotations

import contextlib
import os
import signal

from abb_ros.commands.shared.errors import UsageError
from abb_ros.commands.shared.signals import signals_deferred


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

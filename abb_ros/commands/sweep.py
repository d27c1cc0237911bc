"""`abb-sim sweep SPEC.yaml --out DIR`: a design study over many drives on Dask (docs/sweep.md).

Without ``--scheduler`` a ``distributed.LocalCluster`` is started on this machine (``--workers``
processes, one thread each, bound to 127.0.0.1) and closed at the end; with
``--scheduler tcp://HOST:PORT`` the sweep runs on that cluster (its workers need only this
package). Results go to a Parquet dataset in DIR, one file per partition; ``--resume``
finishes an interrupted sweep without recomputing the partitions already written.
"""

from __future__ import annotations

import os
import sys

from abb_ros.commands.api import UsageError, signals_deferred


def add_arguments(parser) -> None:
    """Add the options of `abb-sim sweep` to ``parser``."""
    parser.add_argument('spec', help='sweep spec (YAML), e.g. config/sweeps/tolerance_p3.yaml')
    parser.add_argument('--out', required=True, help='output directory (Parquet dataset)')
    parser.add_argument('--workers', type=int, default=None,
                        help='worker processes of the local cluster (default: CPU count)')
    parser.add_argument('--scheduler', help='address of a running Dask scheduler, '
                        'tcp://HOST:PORT (default: start a local cluster)')
    parser.add_argument('--resume', action='store_true',
                        help='finish the sweep in --out: compute only the missing partitions')
    parser.add_argument('--serial', action='store_true',
                        help='no Dask: compute the partitions in this process, in order')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')


def _check_options(args) -> None:
    """Refuse option combinations that contradict each other (UsageError)."""
    if args.workers is not None and args.scheduler:
        raise UsageError('--workers applies to the local cluster only; leave it out with '
                         '--scheduler')
    if args.serial and (args.scheduler or args.workers is not None):
        raise UsageError('--serial runs in this process: leave out --scheduler and --workers')
    if args.workers is not None and not 1 <= args.workers <= 256:
        raise UsageError(f'--workers {args.workers}: valid range is 1..256')


def _connect(args):
    """Return (cluster, client) of the options: (None, None) with --serial.

    Returns
    -------
    cluster : distributed.LocalCluster or None
        The local cluster started here (None for --scheduler or --serial).
    client : distributed.Client or None
        The client of the sweep's tasks.
    """
    if args.serial:
        return None, None
    from distributed import Client

    from abb_ros.sweep.runner import local_cluster
    cluster = None
    if args.scheduler:
        try:
            client = Client(args.scheduler, timeout='20s')
        except (OSError, TimeoutError, ValueError) as exc:
            raise UsageError(f'--scheduler {args.scheduler}: cannot connect ({exc})') from None
    else:
        # a signal while the cluster starts is held until it stands, then unwinds through the
        # close below (never a half-made cluster that distributed's atexit hook trips over)
        try:
            with signals_deferred():
                cluster = local_cluster(args.workers or os.cpu_count() or 1, dashboard=True)
                client = Client(cluster)
        except BaseException:
            if cluster is not None:
                cluster.close()
            raise
    if _has_dashboard(client):
        print(f'abb-sim sweep: Dask dashboard at {client.dashboard_link}', file=sys.stderr)
    return cluster, client


def run(args) -> dict:
    """Run the spec's sweep on a Dask cluster into the output directory; return the summary."""
    from abb_ros.sweep.runner import SweepError, check_out_dir, run_sweep
    from abb_ros.sweep.spec import load_spec

    _check_options(args)
    spec = load_spec(args.spec)
    try:
        check_out_dir(spec, args.out, args.resume)   # before a cluster is started
    except SweepError as exc:
        raise UsageError(str(exc)) from None
    bar = None
    if not args.no_progress:
        from tqdm import tqdm
        bar = tqdm(total=spec.total, unit='drive', file=sys.stderr, desc=f'sweep {spec.name}',
                   smoothing=0.1)
    cluster = client = None
    try:
        cluster, client = _connect(args)
        try:
            result = run_sweep(spec, args.out, client, resume=args.resume,
                               progress=bar.update if bar else None)
        except SweepError as exc:
            raise UsageError(str(exc)) from None
        workers = len(client.scheduler_info()['workers']) if client is not None else 0
    finally:
        if bar is not None:
            bar.close()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    return _summary(spec, result, args, workers)


def _has_dashboard(client) -> bool:
    """Return whether the scheduler serves the Dask dashboard.

    A scheduler serves the dashboard on its HTTP server only with bokeh installed; for a
    remote scheduler this machine's bokeh is the best guess there is.
    """
    from abb_ros.sweep.runner import has_bokeh
    try:
        return has_bokeh() and 'dashboard' in client.scheduler_info().get('services', {})
    except Exception:  # noqa: BLE001 - an old scheduler without the field: say nothing
        return False


def _summary(spec, result, args, workers) -> dict:
    from abb_ros.sweep.store import read_results
    table, _ = read_results(result.out_dir)
    balanced = table.column('balanced').to_numpy()
    out = {'name': spec.name, 'out': result.out_dir, 'samples': result.samples,
           'partitions': result.partitions, 'partitions_computed': len(result.computed),
           'partitions_resumed': len(result.skipped),
           'scheduler': args.scheduler or ('serial' if args.serial else 'local'),
           'workers': workers, 'balanced_fraction': float(balanced.mean()),
           'wall_time_s': round(result.wall_time, 3)}
    if 'failed' in table.column_names:
        out['failed_runs'] = int(table.column('failed').to_numpy().sum())
    return out

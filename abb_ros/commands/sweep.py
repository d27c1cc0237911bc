"""`abb-sim sweep SPEC.yaml --out DIR`: a design study over many drives on Dask (docs/sweep.md).

Without ``--scheduler`` a ``distributed.LocalCluster`` is started on this machine (``--workers``
processes, one thread each, bound to 127.0.0.1) and closed at the end; with
``--scheduler tcp://HOST:PORT`` the sweep runs on that cluster (its workers need only this
package). Results go to a Parquet dataset in DIR, one file per partition; ``--resume``
finishes an interrupted sweep without recomputing the partitions already written.
"""

from __future__ import annotations

import sys

from abb_ros.commands.api import UsageError, add_dask_arguments, check_dask_options


def add_arguments(parser) -> None:
    """Add the options of `abb-sim sweep` to ``parser``."""
    parser.add_argument('spec', help='sweep spec (YAML), e.g. config/sweeps/tolerance_p3.yaml')
    parser.add_argument('--out', required=True, help='output directory (Parquet dataset)')
    add_dask_arguments(parser, 'sweep')


def run(args) -> dict:
    """Run the spec's sweep on a Dask cluster into the output directory; return the summary."""
    from abb_ros.commands.api import dask_client
    from abb_ros.sweep.runner import SweepError, check_out_dir, run_sweep
    from abb_ros.sweep.spec import load_spec

    check_dask_options(args.scheduler, args.workers, args.serial)
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
    try:
        with dask_client('sweep', args.scheduler, args.workers, args.serial) as client:
            try:
                result = run_sweep(spec, args.out, client, resume=args.resume,
                                   progress=bar.update if bar else None)
            except SweepError as exc:
                raise UsageError(str(exc)) from None
            workers = len(client.scheduler_info()['workers']) if client is not None else 0
    finally:
        if bar is not None:
            bar.close()
    return _summary(spec, result, args, workers)


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

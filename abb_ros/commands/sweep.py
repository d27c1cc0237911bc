"""`abb-sim sweep SPEC.yaml --out DIR`: a design study over many drives on Dask (docs/sweep.md).

Without ``--scheduler`` a ``distributed.LocalCluster`` is started on this machine (``--workers``
processes, one thread each, bound to 127.0.0.1) and closed at the end; with
``--scheduler tcp://HOST:PORT`` the sweep runs on that cluster (its workers need only this
package). Results go to a Parquet dataset in DIR, one file per partition; ``--resume``
finishes an interrupted sweep without recomputing the partitions already written.
"""

from __future__ import annotations

from abb_ros.commands.shared.cluster import add_dask_arguments, check_dask_options
from abb_ros.commands.shared.errors import UsageError


def add_arguments(parser) -> None:
    """Add the options of `abb-sim sweep` to ``parser``."""
    parser.add_argument('spec', help='sweep spec (YAML), e.g. config/sweeps/tolerance_p3.yaml')
    parser.add_argument('--out', required=True, help='output directory (Parquet dataset)')
    add_dask_arguments(parser, 'sweep')


def run(args) -> dict:
    """Run the spec's sweep on a Dask cluster into the output directory; return the summary."""
    from abb_ros.commands.shared.cluster import run_on_dask
    from abb_ros.commands.shared.outputs import writable_directory
    from abb_ros.sweep.runner import SweepError, check_out_dir, run_sweep
    from abb_ros.sweep.spec import load_spec

    check_dask_options(args.scheduler, args.workers, args.serial)
    spec = load_spec(args.spec)
    try:
        check_out_dir(spec, args.out, args.resume)   # before a cluster is started
    except SweepError as exc:
        raise UsageError(str(exc)) from None
    writable_directory('--out', args.out)
    result, workers = run_on_dask(
        'sweep', args, spec.total, 'drive', f'sweep {spec.name}',
        lambda client, progress: run_sweep(spec, args.out, client, resume=args.resume,
                                           progress=progress))
    return _summary(spec, result, args, workers)


def _summary(spec, result, args, workers) -> dict:
    from abb_ros.sweep.store import SweepFileError, read_results
    try:
        table, _ = read_results(result.out_dir)
    except SweepFileError as exc:
        raise UsageError(str(exc)) from None
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

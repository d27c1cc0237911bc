"""`abb-sim basin`: the probability of balancing from many initial ball positions (docs/basin.md).

The scenario (drive, speed profile, deck start) with any ``--set`` is run from a grid of
starts (n = 2, ``--res NxM``) or from ``--samples K`` uniform random starts, on Dask like
``abb-sim sweep``; each end is classified (balanced or a named unbalanced state) and
``DIR/basin.parquet``, ``DIR/basin.json`` and ``DIR/basin.png`` are written.
"""

from __future__ import annotations


def add_arguments(parser) -> None:
    """Add the options of `abb-sim basin` to ``parser``."""
    from abb_ros.commands.shared.cluster import add_dask_arguments
    parser.add_argument('--scenario', default='p3',
                        help='a shipped scenario or a YAML file (default: %(default)s)')
    parser.add_argument('--config', help='ROS 2 parameter file with drive.* parameters')
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='as abb-sim run --set (drive, spindle.*, integration_rate_hz, '
                        'publish_rate_hz); repeatable')
    parser.add_argument('--duration', type=float, help='simulated seconds per start '
                        '(default: the scenario\'s)')
    starts = parser.add_mutually_exclusive_group(required=True)
    starts.add_argument('--res', metavar='NxM', help='n = 2: a grid of N x M starts over '
                        '(phi1, phi2) in [-180, 180) deg')
    starts.add_argument('--samples', type=int, metavar='K',
                        help='K starts, every ball angle uniform on [-180, 180) deg')
    parser.add_argument('--seed', type=int, default=0, help='seed of --samples (numpy '
                        'default_rng, PCG64; default: %(default)s)')
    parser.add_argument('--integrator', choices=('rk4', 'adaptive'), default='rk4',
                        help='as abb-sim run --integrator: rk4, the fixed step (default), or '
                        'adaptive, Dormand-Prince 5(4) with error control (the fixed step '
                        'with contact or rolling resistance)')
    parser.add_argument('--rbar-limit', type=float, default=1e-3,
                        help='largest final rbar of a balanced end (default: %(default)g)')
    parser.add_argument('--rest-tol', type=float, metavar='DEG',
                        help='largest motion of a ball at rest in the rest window (default: '
                        'REST_TOL_DEG of abb_ros/model/stability/outcomes.py, docs/basin.md)')
    parser.add_argument('--partition-size', type=int, default=32,
                        help='starts per Dask task and per part file (default: %(default)s)')
    parser.add_argument('--out', required=True, help='output directory')
    add_dask_arguments(parser, 'study')


def run(args) -> dict:
    """Run the basin study into --out and return its summary."""
    from abb_ros.basin.spec import BasinSpec, parse_res
    from abb_ros.basin.study import check_out, run_basin
    from abb_ros.commands.shared.cluster import check_dask_options, run_on_dask
    from abb_ros.commands.shared.errors import UsageError
    from abb_ros.commands.shared.inputs import run_scenario_from_args
    from abb_ros.commands.shared.outputs import writable_directory
    from abb_ros.model.stability.outcomes import REST_TOL_DEG
    from abb_ros.sweep.runner import SweepError

    check_dask_options(args.scheduler, args.workers, args.serial)
    scenario, options = run_scenario_from_args(args.scenario, args.config, args.set,
                                               duration=args.duration)
    options = {k: v for k, v in options.items() if k in ('dt', 'publish_dt')}
    options['integrator'] = args.integrator
    rest_tol = REST_TOL_DEG if args.rest_tol is None else args.rest_tol
    spec = BasinSpec(scenario, options, sorted(args.set), args.rbar_limit, rest_tol,
                     res=parse_res(args.res) if args.res else None, samples=args.samples,
                     seed=args.seed, partition_size=args.partition_size)
    try:
        check_out(spec, args.out, args.resume)    # before a cluster is started
    except SweepError as exc:
        raise UsageError(str(exc)) from None
    writable_directory('--out', args.out)
    summary, workers = run_on_dask(
        'basin', args, spec.total, 'start', f'basin {scenario.name}',
        lambda client, progress: run_basin(spec, args.out, client, resume=args.resume,
                                           progress=progress))
    return {**summary, 'out': str(args.out), 'workers': workers,
            'scheduler': args.scheduler or ('serial' if args.serial else 'local')}

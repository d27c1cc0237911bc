"""`abb-sim sweep-report DIR --out FIG`: the PNG figures and summary.json of a sweep.

See abb_ros/sweep/report.py and docs/sweep.md.
"""

from __future__ import annotations

from abb_ros.commands.shared.errors import UsageError
from abb_ros.commands.shared.outputs import check_output


def add_arguments(parser) -> None:
    """Add the options of `abb-sim sweep-report` to ``parser``."""
    parser.add_argument('sweep_dir', metavar='DIR', help='output directory of abb-sim sweep')
    parser.add_argument('--out', required=True, help='directory for the PNGs and summary.json')


def run(args) -> dict:
    """Write the sweep's figures and summary.json; return the key figures of the summary."""
    from abb_ros.sweep.report import make_report
    from abb_ros.sweep.store import SweepFileError
    out = check_output('--out', args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f'--out {out}: it exists and is not a directory (the report writes '
                         'PNGs and summary.json into a directory)')
    try:
        summary = make_report(args.sweep_dir, args.out)
    except (FileNotFoundError, NotADirectoryError) as exc:
        raise UsageError(f'{args.sweep_dir}: {exc}') from None
    except SweepFileError as exc:
        raise UsageError(str(exc)) from None
    keep = ('name', 'samples', 'samples_planned', 'yield', 'yield_all_speeds',
            'run_balanced_fraction', 'run_status_counts', 'influence_abs_spearman', 'figures')
    return {'out': str(args.out), **{k: summary[k] for k in keep if k in summary}}

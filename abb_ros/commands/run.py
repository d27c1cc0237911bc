"""`abb-sim run`: a scenario integrated headless (no DDS), optionally written to a bag.

A run that cannot write its bag (full disk) removes it, exit code 1; a run whose state blows up
keeps the bag written so far, marked incomplete in its metadata.yaml (exit code 1).
"""

from __future__ import annotations

import argparse
import errno
import os
import shutil
import sys

DEFAULT_SCENARIO = 'p3'


def add_arguments(parser):
    """Add the options of ``abb-sim run`` to ``parser``."""
    parser.add_argument('--config', help='ROS 2 parameter file with drive.* parameters '
                        '(default: Table 1, config/cdrom_table1.yaml)')
    from abb_ros.io.files.scenario import list_scenarios
    parser.add_argument('--scenario', default=DEFAULT_SCENARIO,
                        help=f'{", ".join(list_scenarios())} (config/scenarios) or a YAML '
                        'file (default: %(default)s)')
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='SI (k, c, eps, m, n, omega, ...) or Eq. (39) name (wbar, zeta, '
                        'Dbar, epsbar, mbar), or a simulator node parameter that applies '
                        'headless (imu.*, seed, spindle.*, integration_rate_hz, '
                        'publish_rate_hz; spindle.max_accel/tau select the motor model); '
                        'repeatable (docs/parameters.md)')
    parser.add_argument('--duration', type=float, help='simulated seconds (default: scenario)')
    parser.add_argument('--integrator', choices=('rk4', 'adaptive'), default='rk4',
                        help='rk4: the fixed step of the live node (a bag equals the node\'s '
                        'byte for byte); adaptive: Dormand-Prince 5(4) with error control, '
                        'sampled at the same stamps, several times faster; it takes the '
                        'fixed step for drives with ball contact or rolling resistance '
                        '(default: %(default)s)')
    parser.add_argument('--out', help='write a rosbag2 MCAP directory here')
    parser.add_argument('--overwrite', action='store_true', help='replace an existing --out')
    parser.add_argument('--no-abb', action='store_true', help='the drive without balls (n = 0)')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')
    parser.add_argument('--live-view', metavar='[HOST:]PORT',
                        help='serve the messages on a Foxglove WebSocket server (the Foxglove '
                        'app opens ws://HOST:PORT; HOST default 127.0.0.1, PORT 0: any free '
                        'port); it stops when the run ends')
    parser.add_argument('--real-time', action=argparse.BooleanOptionalAction,
                        help='pace the run at the wall clock, 1 simulated second per second '
                        '(default: with --live-view; else as fast as possible)')


def _why(exc: OSError) -> str:
    """Return what the system said, without the path (the message names the option)."""
    return os.strerror(exc.errno) if exc.errno else str(exc)


def _live_view(address: str | None):
    """Start the live view of ``--live-view [HOST:]PORT`` (None without the option).

    It starts before any file is made, so one that cannot listen leaves nothing behind.
    """
    if address is None:
        return None
    from abb_ros.commands.shared.errors import UsageError
    from abb_ros.io.live_view.rate_cap import DEFAULT_MAX_RATE_HZ
    from abb_ros.io.live_view.server import LiveView, LiveViewError, parse_address
    try:
        live = LiveView(*parse_address(address), server_time=True,
                        log=lambda line: print(line, file=sys.stderr, flush=True),
                        max_rate_hz=DEFAULT_MAX_RATE_HZ)
    except (ValueError, LiveViewError) as exc:
        raise UsageError(f'--live-view {address}: {exc}') from None
    print(f'live view on {live.url} (Foxglove app: Open connection, Foxglove WebSocket)',
          file=sys.stderr, flush=True)
    return live


def _finish(bag, path, staged) -> None:
    """Close the bag (signals held meanwhile) and move it into place; a failed close removes it."""
    from abb_ros.commands.shared.errors import CommandFailed
    from abb_ros.commands.shared.outputs import commit_directory
    from abb_ros.commands.shared.signals import signals_deferred
    from abb_ros.io.bag.writer import BagWriteError
    try:
        with signals_deferred():
            bag.close()
    except BagWriteError as exc:
        shutil.rmtree(staged, ignore_errors=True)
        raise CommandFailed(f'--out {path}: finishing the bag failed ({_why(exc)}); the '
                            'partial bag was removed') from None
    finally:
        commit_directory(path, staged)


def _scenario(args):
    """Return the scenario of the options and run_scenario's keyword arguments.

    ``--config``, ``--set``, ``--no-abb`` and ``--duration`` applied to ``--scenario``, all
    checked before a file is made (:func:`abb_ros.commands.shared.inputs.run_scenario_from_args`).
    """
    from abb_ros.commands.shared.inputs import run_scenario_from_args
    return run_scenario_from_args(args.scenario, args.config, args.set, args.no_abb,
                                  args.duration)


def _open_bag(args, staged, params, live):
    """Open the bag of ``--out`` in ``staged``; a failure closes ``live`` and removes it.

    Called with signals held (:func:`_integrate`), so a signal cannot part the bag from its
    caller.
    """
    from abb_ros.commands.shared.errors import CommandFailed, UsageError
    from abb_ros.commands.shared.outputs import commit_directory
    from abb_ros.io.bag.writer import BagError, BagExistsError, BagWriter
    try:
        bag = BagWriter(staged)
        bag.set_drive_params(params)
        return bag
    except (BagError, OSError) as exc:
        if live is not None:
            live.close()
        shutil.rmtree(staged, ignore_errors=True)
        commit_directory(args.out, staged)
        if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise CommandFailed(f'--out {args.out}: {_why(exc)}; nothing was written'
                                ) from None
        if isinstance(exc, BagExistsError):
            raise UsageError(f'--out {args.out}: it exists; pass --overwrite to replace it'
                             ) from None
        why = _why(exc) if isinstance(exc, OSError) else str(exc)
        raise UsageError(f'--out {args.out}: {why}') from None


def _progress_bar(args, scenario):
    """Return the tqdm bar of the run (None with ``--no-progress``)."""
    if args.no_progress:
        return None
    from tqdm import tqdm
    return tqdm(total=round(scenario.duration, 6), unit='sim s', file=sys.stderr,
                desc=f'abb-sim run {scenario.name}', leave=False,
                bar_format='{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]')


def _integrate(args, scenario, options, live, staged):
    """Open the bag (``--out``), run the scenario into it and the live view, close both.

    Whatever happens: a signal from the bag's opening on leaves it closed and marked.
    """
    from abb_ros.app.headless import run_scenario
    from abb_ros.app.run_sinks import Sinks
    from abb_ros.commands.shared.errors import CommandFailed
    from abb_ros.commands.shared.signals import signals_deferred, stop_point
    from abb_ros.io.bag.writer import BagWriteError
    from abb_ros.model.dynamics.integrate import StateError
    bag = bar = None
    try:
        with signals_deferred():    # a signal stops the run between chunks (stop_point)
            if staged is not None:
                bag = _open_bag(args, staged, scenario.params, live)
            sinks = [sink for sink in (bag, live) if sink is not None]
            real_time = live is not None if args.real_time is None else args.real_time
            sink = Sinks(sinks, real_time) if sinks else None
            bar = _progress_bar(args, scenario)
            return run_scenario(scenario, bag=sink, progress=stop_point(
                bar.update if bar else None), integrator=args.integrator, **options)
    except StateError as exc:
        if bag is not None:
            bag.mark_incomplete(str(exc))
        raise
    except BagWriteError as exc:
        shutil.rmtree(staged, ignore_errors=True)
        raise CommandFailed(f'--out {args.out}: writing the bag failed ({_why(exc)}); '
                            'the partial bag was removed') from None
    except BaseException:
        if bag is not None:
            with signals_deferred():
                bag.mark_incomplete('the run was interrupted')
        raise
    finally:
        if bar is not None:
            bar.close()
        if live is not None:
            live.close()
        if bag is not None:
            _finish(bag, args.out, staged)


def run(args) -> dict:
    """Run the scenario headless (a bag with ``--out``) and return the summary."""
    from abb_ros.app.run_settings import summary
    from abb_ros.commands.shared.outputs import stage_directory
    scenario, options = _scenario(args)
    staged = stage_directory('--out', args.out, args.overwrite) if args.out else None
    live = _live_view(args.live_view)
    result = _integrate(args, scenario, options, live, staged)
    out = summary(scenario, result)
    if live is not None:
        out['live_view'] = live.url
    if args.out:
        out['bag'] = str(args.out)
        out['messages'] = result.messages
    return out

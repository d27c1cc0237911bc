"""`abb-sim`: the command line of abb_ros (docs/architecture.md).

Each subcommand lives in ``abb_ros/commands/<name>.py`` and provides
``add_arguments(parser)`` and ``run(args) -> dict``. The dict is the summary: printed as
one JSON object with ``--json``, as ``key: value`` lines otherwise. Bad input
(:class:`~abb_ros.model.parameters.params.ParamError`, :class:`UsageError`) exits with code 2 and a
message naming the parameter and its valid range; a simulation whose state blows up
(:class:`~abb_ros.model.dynamics.integrate.StateError`), a command that cannot finish
(:class:`CommandFailed`, e.g. a full disk) or any other refusal of the operating system
(``OSError``) exits with code 1, and so does a computation whose numbers overflow (numpy's
warnings are errors here, never text beside a result). SIGINT exits with code 130 and SIGTERM
with 143, at any moment from the first statement of the console script (:func:`script`,
before the dispatcher's imports): the commands' ``finally`` blocks run
(a bag is finished and marked incomplete). Every error is one line on stderr.
"""

from __future__ import annotations

import signal
import sys

__all__ = ['main', 'script', 'SUBCOMMANDS']

SUBCOMMANDS = {
    'run': 'headless simulation (no DDS) written to a rosbag2 MCAP directory',
    'stability': 'in-plane and out-of-plane max |Floquet multiplier| at an operating point',
    'freqs': 'natural frequencies of Eqs. (27)-(32) with m = omega = 0',
    'map': 'stability map over two parameters (PNG + data file)',
    'plot': 'time-response figures (PNG) from a recorded bag',
    'sweep': 'design study over many drives with tolerances, on Dask (Parquet dataset)',
    'sweep-report': 'figures (PNG) and a JSON summary of a sweep directory',
    'basin': 'probability of balancing from many initial ball positions, on Dask (PNG, Parquet)',
}


def script() -> None:
    """Run ``abb-sim`` as its console script: note SIGINT and SIGTERM first, then load.

    Its first statement installs handlers that only note a signal, so one that arrives while
    the dispatcher and numpy load (a second or more on a loaded machine) ends ``abb-sim`` with
    its line and exit code (130, 143), never a KeyboardInterrupt traceback from inside an
    import; they stay after :func:`main`, so a signal during the interpreter's exit is quiet
    too. This module imports only ``signal`` and ``sys`` before that; importing it installs
    nothing (tests call :func:`main` in-process).
    """
    early = []
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda number, _frame: early.append(number))
    sys.exit(main(early=early))


def _parser_class():
    import argparse

    class _Parser(argparse.ArgumentParser):
        """argparse with one-line errors (no usage block): ``abb-sim run: error: ...``."""

        def error(self, message):
            self.exit(2, f'{self.prog}: error: {message} (see {self.prog} --help)\n')

    return _Parser


def build_parser() -> argparse.ArgumentParser:  # noqa: F821 - argparse is imported lazily
    parser = _parser_class()(
        prog='abb-sim', description='Optical disk drive with an automatic ball balancer.')
    sub = parser.add_subparsers(dest='command', required=True)
    for name, help_text in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.add_argument('--json', action='store_true', help='print one JSON object on stdout')
        _load(name).add_arguments(p)
    return parser


def _load(name):
    import importlib
    return importlib.import_module(f"abb_ros.commands.{name.replace('-', '_')}")


class _NotRaised(Exception):
    """Stands for an exception class whose module no command has imported."""


def _state_error():
    """Return integrate.StateError if a command imported the integrator, else a stand-in.

    The parser starts without numba: argument errors and --help come at once.
    """
    module = sys.modules.get('abb_ros.model.dynamics.integrate')
    return module.StateError if module is not None else _NotRaised


def _family_error():
    """Return floquet.FamilyInvarianceError if a command imported the Floquet module."""
    module = sys.modules.get('abb_ros.model.stability.floquet')
    return module.FamilyInvarianceError if module is not None else _NotRaised


def _print_human(summary: dict) -> None:
    for key, value in summary.items():
        print(f'{key}: {value}')


def main(argv=None, early=()) -> int:
    """Run the `abb-sim` command line ``argv``; return the exit status (0, 1 failed, 2 usage).

    ``early``: the signals that arrived before this was called (the console script,
    :func:`script`, collects them while the imports run), appended to until this
    function's own handlers are in place; any of them stops the command before it starts.
    """
    who = ['abb-sim']     # with the subcommand once it is known
    try:
        from abb_ros.commands.shared.errors import Terminated
        from abb_ros.commands.shared.signals import stop_signals
        with stop_signals():
            try:
                if early:
                    raise KeyboardInterrupt if early[0] == signal.SIGINT else \
                        Terminated(early[0])
                import warnings
                with warnings.catch_warnings():
                    warnings.simplefilter('error', RuntimeWarning)
                    return _dispatch(argv, who)
            except Terminated:
                print(f'{who[0]}: terminated', file=sys.stderr)
                return 143
    except KeyboardInterrupt:
        print(f'{who[0]}: interrupted', file=sys.stderr)
        return 130


def _dispatch(argv, who: list) -> int:
    from abb_ros.commands.shared.errors import CommandFailed, UsageError
    from abb_ros.model.parameters.params import ParamError
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:    # --help (0) or a usage error, already printed (2)
        return exc.code if isinstance(exc.code, int) else 2
    who[0] = f'abb-sim {args.command}'
    module = _load(args.command)
    try:
        summary = module.run(args)
    except (ParamError, UsageError) as exc:
        print(f'abb-sim {args.command}: error: {exc}', file=sys.stderr)
        return 2
    except _state_error() as exc:   # the physics blew up: say so, keep what was written
        print(f'abb-sim {args.command}: simulation stopped: {exc} (check the parameters: '
              'a very stiff or undamped drive may need a smaller step)', file=sys.stderr)
        return 1
    except (CommandFailed, _family_error()) as exc:
        print(f'abb-sim {args.command}: error: {exc}', file=sys.stderr)
        return 1
    except OSError as exc:      # refused by the system where no command expected it
        where = f': {exc.filename}' if exc.filename else ''
        print(f'abb-sim {args.command}: error: {exc.strerror or exc}{where}', file=sys.stderr)
        return 1
    except (ArithmeticError, RuntimeWarning, _linalg_error()) as exc:
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        print(f'abb-sim {args.command}: error: the computation failed numerically ({why}); '
              'the parameters are beyond what it resolves', file=sys.stderr)
        return 1
    if args.json:
        import json
        print(json.dumps(summary, default=_jsonable))
    else:
        _print_human(summary)
    return 0


def _linalg_error():
    """Return numpy's LinAlgError if numpy is loaded, else a stand-in."""
    module = sys.modules.get('numpy.linalg')
    return module.LinAlgError if module is not None else _NotRaised


def _jsonable(obj):
    try:
        import numpy as np
        if isinstance(obj, np.generic):
            return obj.item()
        if isinstance(obj, np.ndarray):
            return obj.tolist()
    except ImportError:  # pragma: no cover
        pass
    raise TypeError(f'not JSON serialisable: {type(obj).__name__}')


if __name__ == '__main__':
    sys.exit(main())

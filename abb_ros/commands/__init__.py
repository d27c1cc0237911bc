"""Subcommands of `abb-sim` (see abb_ros/cli.py): each has add_arguments(parser) and run(args)."""


class UsageError(Exception):
    """Bad command-line input that is not a single parameter (exit code 2).

    Defined here rather than in abb_ros.cli so that ``python -m abb_ros.cli`` (where cli is
    ``__main__``) and the subcommands share one class.
    """

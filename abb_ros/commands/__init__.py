"""Subcommands of `abb-sim` (dispatched by abb_ros/cli.py): each module has
``add_arguments(parser)`` and ``run(args) -> dict``; shared helpers are in :mod:`.api`."""

"""Subcommands of `abb-sim`, dispatched by abb_ros/cli.py.

Each module has ``add_arguments(parser)`` and ``run(args) -> dict``; shared helpers are in
:mod:`.api`.
"""

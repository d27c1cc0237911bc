"""Subcommands of `abb-sim` (see abb_ros/cli.py): each has add_arguments(parser) and run(args)."""

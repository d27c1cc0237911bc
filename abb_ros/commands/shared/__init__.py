"""What the `abb-sim` subcommands share, importable without the dispatcher (abb_ros/cli.py).

A subcommand imports from these modules, one concern each; the dispatcher imports the
subcommands; nothing imports the dispatcher.
"""

"""``python -m abb_ros.nodes.simulator``: the stop handlers first, then the node."""

from abb_ros.nodes.ros.script import run_module

run_module('abb_ros.nodes.simulator.node')

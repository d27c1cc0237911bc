"""``python -m abb_ros.nodes.spin_controller``: the stop handlers first, then the node."""

from abb_ros.nodes.ros.script import run_module

run_module('abb_ros.nodes.spin_controller.node')

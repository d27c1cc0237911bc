"""``python -m abb_ros.nodes.analysis``: the stop handlers first, then the node."""

from abb_ros.nodes.ros.script import run_module

run_module('abb_ros.nodes.analysis.node')

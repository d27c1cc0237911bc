"""rclpy nodes: thin adapters over abb_ros.model."""

from abb_ros.nodes import stop as _stop

if _stop.starting_a_node():
    _stop.install()

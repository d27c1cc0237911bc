"""rclpy nodes: thin adapters over abb_ros.model."""

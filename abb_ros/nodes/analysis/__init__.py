"""The analysis node (``ros2 run abb_ros analysis``): node, parameters, verdict table."""

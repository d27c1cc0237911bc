"""The simulator node (``ros2 run abb_ros simulator``).

The node, its plant loop, parameters, diagnostics, live view, simulation_interfaces server,
HIL I/O and in-process recording.
"""

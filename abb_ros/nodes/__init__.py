"""The rclpy nodes, one room each.

simulator/, analysis/, recorder/, spin_controller/, and what they share (ros/: entry point,
parameters, taps, stop handlers).
"""

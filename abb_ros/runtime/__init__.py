"""The plant in real time, without ROS.

Pacing and the simulated clock, the plant thread, real-time scheduling, the run state of the
simulation standard, rate slots and the spindle commands: what the simulator node runs, and
what tests run without a node.
"""

"""What every node shares: the entry point, stop handlers, ROS parameters and taps.

The parameter files and the table of which node declares which parameter live here too.
"""

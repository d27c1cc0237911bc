"""Applications of the model without ROS: the headless run (abb-sim run)."""

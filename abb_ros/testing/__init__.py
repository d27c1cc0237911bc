"""Helpers for tests of controllers and nodes against the plant (no ROS needed to import)."""

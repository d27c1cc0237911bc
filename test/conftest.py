"""Session set-up shared by all tests: keep DDS traffic private to this run, register markers.

Runs at import time, before any test module imports rclpy: DDS reads ROS_DOMAIN_ID and
ROS_AUTOMATIC_DISCOVERY_RANGE when a context is initialised, and subprocesses inherit them.
"""

import os
import random

import pytest

# 1..101: inside the range whose Fast DDS ports are valid on Linux; random so that concurrent
# runs on the same machine rarely share a domain. A value set by the caller wins.
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')


def pytest_configure(config):
    config.addinivalue_line('markers', 'ros: uses rclpy over DDS (real nodes, real middleware)')
    config.addinivalue_line('markers', 'slow: takes more than a few seconds')


@pytest.fixture
def abb_sim(capsys):
    """``abb_sim(*args) -> (exit code, stdout, stderr)`` of ``abb-sim`` run in this process."""
    def run(*args):
        from abb_ros.cli import main
        code = main(list(args))
        out = capsys.readouterr()
        return code, out.out, out.err
    return run

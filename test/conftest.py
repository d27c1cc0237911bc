"""Session set-up shared by all tests: keep DDS traffic private to this run, register markers.

Runs at import time, before any test module imports rclpy: DDS reads ROS_DOMAIN_ID and
ROS_AUTOMATIC_DISCOVERY_RANGE when a context is initialised, and subprocesses inherit them.
"""

import os
import random
import sys
from pathlib import Path

import pytest

TEST_ROOT = Path(__file__).resolve().parent
"""test/: the shared helpers (paper_reference, lagrange_sympy, ...) and the data directory."""

# test/ mirrors the package (test/model/stability/, test/nodes/simulator/, ...). The folders hold
# no __init__.py, so pytest imports each test module by its basename (every basename is unique
# in the tree, as pytest's rootdir-relative import requires) and modules import shared helpers
# from one another by name: put every folder of the tree on sys.path before any is collected,
# so that the order in which pytest reaches the folders does not matter.
for _folder in sorted({path.parent for path in TEST_ROOT.rglob('test_*.py')
                       if 'node_modules' not in path.parts}, reverse=True):
    if str(_folder) not in sys.path:
        sys.path.insert(0, str(_folder))

# 1..101: inside the range whose Fast DDS ports are valid on Linux; random so that concurrent
# runs on the same machine rarely share a domain. A value set by the caller wins.
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')


SLOW_RULE = (
    'slow: takes more than about 1.5 s on the shared 2-core machine under load (a parametrized '
    'test: all its cases together), typically because it starts a node or abb-sim process, '
    'simulates seconds of the drive or waits out wall-clock periods over DDS. The one fast '
    'test of a behaviour that no other fast test reaches (a node start-up error, the abb-sim '
    'entry point) stays unmarked while it is cheap. `scripts/test -m "not slow"` must stay '
    'under 60 s on such a machine; the full suite (`scripts/test`, what CI runs) runs every '
    'test.')
"""The rule for the ``slow`` marker, registered (and shown by ``pytest --markers``) as is."""


def pytest_configure(config):
    config.addinivalue_line('markers', 'ros: uses rclpy over DDS (real nodes, real middleware)')
    config.addinivalue_line('markers', SLOW_RULE)


@pytest.fixture
def abb_sim(capsys):
    """``abb_sim(*args) -> (exit code, stdout, stderr)`` of ``abb-sim`` run in this process."""
    def run(*args):
        from abb_ros.cli import main
        code = main(list(args))
        out = capsys.readouterr()
        return code, out.out, out.err
    return run

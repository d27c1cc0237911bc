"""pytest plugin of abb_ros (entry point ``pytest11``): the ``lockstep_plant`` fixture.

``lockstep_plant(parameters=None, **options)`` starts a :class:`abb_ros.testing.lockstep.
LockstepPlant` (same arguments) and closes every plant it started when the test ends. At
start-up the plugin keeps DDS on this machine (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST) and on
a random ROS_DOMAIN_ID in 1..101, unless the environment sets them: then concurrent test runs
do not meet. Importing this module does not import rclpy.
"""

import os
import random

import pytest


def pytest_configure(config):  # noqa: ARG001 (pytest passes hook arguments by name)
    """Keep DDS on this machine and on a random domain, unless the environment says otherwise."""
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')


@pytest.fixture
def lockstep_plant():
    """Provide a factory of lockstep plants (the simulator paused in process, stepped over DDS)."""
    from abb_ros.testing.lockstep import LockstepPlant
    plants = []

    def start(parameters=None, **options):
        plants.append(LockstepPlant(parameters, **options))
        return plants[-1]

    yield start
    for plant in reversed(plants):
        plant.close()

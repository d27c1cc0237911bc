"""A drive with a second race through the simulator node (docs/equations.md, F7).

The node is the headless model behind a ROS interface: race 2's balls follow race 1's in
joint_states and markers.
"""

import numpy as np
import pytest
from sensor_msgs.msg import JointState
from test_hil_io_node import LOCKSTEP, step_periods
from test_simulator_node import NOISE_OFF, Plant
from visualization_msgs.msg import Marker, MarkerArray

pytestmark = pytest.mark.ros

TWO_RACES = {'drive.z_G': 0.001, 'drive.race2.n': 2, 'drive.race2.z': 0.002,
             'drive.race2.m': 0.6e-3}


@pytest.fixture
def plant():
    made = Plant(**LOCKSTEP, **NOISE_OFF, **TWO_RACES, **{'visualization.rate_hz': 1000.0})
    yield made
    made.close()


def test_race_2s_balls_follow_race_1s_in_joint_states_and_markers(plant):
    states = plant.collect(JointState, 'joint_states')
    markers = plant.collect(MarkerArray, 'visualization/markers')
    step_periods(plant, states, 20)
    plant.wait(lambda: len(markers) >= 5, 'markers')
    drive = plant.sim.drive
    assert (drive.n, drive.race2_n, drive.race2_mass) == (2, 2, 0.6e-3)
    assert len(states[-1].name) == 1 + 4 and len(states[-1].position) == 5
    array = markers[-1]
    assert [m.type for m in array.markers] == [Marker.CUBE, Marker.CYLINDER] + [Marker.SPHERE] * 4
    # race 2's spheres ride 2 mm above race 1's (the deck's exaggerated tilt moves both by
    # less than 5 % of that), and its heavier balls are larger
    z = [m.pose.position.z for m in array.markers[2:]]
    assert np.mean(z[2:]) - np.mean(z[:2]) == pytest.approx(0.002, rel=0.05)
    assert array.markers[4].scale.x > array.markers[2].scale.x

"""A headless run's samples do not depend on how its loop is chunked.

``run_scenario`` sizes each call of the compiled loop to about ``CHUNK_WALL_S`` of wall time
(so SIGINT stops a stiff run quickly); which sizes it picks depends on the machine's load.
Both integrators must give bit-identical states and bags whatever the chunking: here the
budget is forced to one publish period per call and compared with the default.
"""
import numpy as np
import pytest

from abb_ros.app import headless
from abb_ros.io.bag.reader import iter_raw
from abb_ros.io.bag.writer import BagWriter
from abb_ros.io.files.scenario import load_scenario


def run(tmp_path, name, integrator):
    scenario = load_scenario('p3')
    scenario.duration = 0.05
    with BagWriter(tmp_path / name) as bag:
        result = headless.run_scenario(scenario, seed=3, bag=bag, integrator=integrator)
    return result.y, [(t, stamp, data) for t, stamp, data, _ in iter_raw(tmp_path / name)]


@pytest.mark.parametrize('integrator', ['rk4', 'adaptive'])
def test_chunk_sizes_change_no_sample_and_no_message(tmp_path, monkeypatch, integrator):
    y_default, bag_default = run(tmp_path, 'default', integrator)
    monkeypatch.setattr(headless, 'CHUNK_WALL_S', 0.0)   # one publish period per call
    y_single, bag_single = run(tmp_path, 'single', integrator)
    assert np.array_equal(y_default, y_single)
    assert bag_default == bag_single

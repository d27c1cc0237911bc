"""Reference trajectories of the paper's model, stored before the ball-size terms existed.

``python test/paper_reference.py`` runs the scenarios P1-P4 and P3 with ten balls (the
shipped config/scenarios, the node's 10 kHz step, states every 100 ms) and writes them to
test/data/paper_reference.npz. The file committed with this module was produced by the code
of commit d139114 (before the ball-size terms); test_zero_ball_size_terms.py compares today's runs
with it bit for bit.
"""

from __future__ import annotations

import os

import numpy as np

SCENARIOS = ('p1', 'p2', 'p3', 'p4', 'p3_n10')
PATH = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'data', 'paper_reference.npz')
STRIDE = 100
"""Every STRIDE-th published state (the headless run publishes at 1 kHz): every 100 ms."""


def run(name: str, **settings) -> np.ndarray:
    """States of scenario ``name`` every 100 ms, shape (rows, 2N)."""
    from abb_ros.app.headless import run_scenario
    from abb_ros.io.files.scenario import load_scenario
    scenario = load_scenario(name)
    if settings:
        scenario = scenario.with_settings(settings)
    return run_scenario(scenario).y[::STRIDE]


def main() -> None:
    arrays = {name: run(name) for name in SCENARIOS}
    np.savez_compressed(PATH, **arrays)
    for name, y in arrays.items():
        print(f'{name}: {y.shape} final phi = {y[-1, 7:7 + (y.shape[1] // 2 - 7)]}')


if __name__ == '__main__':
    main()

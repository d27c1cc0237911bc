"""A sweep over a height (docs/equations.md F4, F5): the coupled linearisation per drive.

A drive with G above the race has no in-plane and out-of-plane groups; its stability columns
hold the coupled lam_max over a spindle period, the same for both, and the nonlinear runs take
the heights as any other drawn parameter.
"""

import pyarrow.parquet as pq
import pytest

from abb_ros.model.parameters.params import DriveParams, apply_settings
from abb_ros.model.stability import coupled

SPEC = """name: zg
description: G above the race at P3
scenario: p3
parameters:
  z_G: {dist: uniform, low: 0.0, high: 0.002}
samples: 4
sampling: {method: sobol, seed: 1}
partition_size: 4
compute:
  stability:
    range: {wbar: [2.2, 3.2], points: 3}
  run: {duration: 0.2, rbar_limit: 1.0e-3}
"""


def test_a_sweep_over_z_g_reports_the_coupled_lam_max_of_each_drive(abb_sim, tmp_path):
    spec = tmp_path / 'zg.yaml'
    spec.write_text(SPEC)
    code, _, err = abb_sim('sweep', str(spec), '--out', str(tmp_path / 'out'), '--serial',
                           '--no-progress', '--json')
    assert code == 0, err
    table = pq.read_table(tmp_path / 'out').to_pydict()
    p3 = DriveParams(c=0.66, m=0.03 * 0.026)
    omega = 2.7 * p3.omega0            # the operating speed: the middle of the range
    for z_g, lam_in, lam_out in zip(table['z_G'], table['lam_in_op'], table['lam_out_op']):
        drive = apply_settings(p3, {'z_G': z_g})[0]
        assert lam_in == lam_out == pytest.approx(coupled.lam_max_sweep(drive, [omega])[0],
                                                  rel=1e-9)
    assert all(v > 0 for v in table['z_G'])

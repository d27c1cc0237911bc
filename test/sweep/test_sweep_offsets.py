"""A sweep over a height (docs/equations.md F4, F5): the coupled linearisation per drive.

A drive with G above the race has no in-plane and out-of-plane groups; its stability columns
hold the coupled lam_max over a spindle period, the same for both, and the nonlinear runs take
the heights as any other drawn parameter.
"""

import pyarrow.parquet as pq
import pytest

from abb_ros.model.parameters.params import DriveParams, apply_settings
from abb_ros.model.stability import coupled

SPEC = """name: {name}
description: {description}
scenario: p3
parameters:
{parameters}
samples: {samples}
sampling: {{method: sobol, seed: {seed}}}
partition_size: {samples}
compute:
  stability:
    range: {{wbar: [2.2, 3.2], points: 3}}
  run: {{duration: 0.2, rbar_limit: 1.0e-3}}
"""
"""A sweep at P3 over ``parameters`` (its YAML lines), with stability at three speeds and runs."""

P3 = DriveParams(c=0.66, m=0.03 * 0.026)
OMEGA = 2.7 * P3.omega0            # the operating speed: the middle of the range


def swept(abb_sim, tmp_path, **fields):
    """Run ``abb-sim sweep`` on SPEC with ``fields`` and return its table (column lists)."""
    spec = tmp_path / f'{fields["name"]}.yaml'
    spec.write_text(SPEC.format(**fields))
    code, _, err = abb_sim('sweep', str(spec), '--out', str(tmp_path / 'out'), '--serial',
                           '--no-progress', '--json')
    assert code == 0, err
    return pq.read_table(tmp_path / 'out').to_pydict()


def test_a_sweep_over_z_g_reports_the_coupled_lam_max_of_each_drive(abb_sim, tmp_path):
    table = swept(abb_sim, tmp_path, name='zg', description='G above the race at P3',
                  parameters='  z_G: {dist: uniform, low: 0.0, high: 0.002}', samples=4, seed=1)
    for z_g, lam_in, lam_out in zip(table['z_G'], table['lam_in_op'], table['lam_out_op']):
        drive = apply_settings(P3, {'z_G': z_g})[0]
        assert lam_in == lam_out == pytest.approx(coupled.lam_max_sweep(drive, [OMEGA])[0],
                                                  rel=1e-9)
    assert all(v > 0 for v in table['z_G'])


def test_a_sweep_over_the_second_races_height_analyses_and_runs_both_races(abb_sim, tmp_path):
    """race2.* are sweep names: each drive's lam_max is the coupled analysis' about its own
    two-plane balance, and its run holds four balls (their final angles in the table)."""
    table = swept(abb_sim, tmp_path, name='race2', samples=3, seed=2,
                  description="a second race about G's mirror image, P3 with G 1 mm up",
                  parameters='  z_G: {dist: list, values: [0.001]}\n'
                             '  race2.n: {dist: list, values: [2]}\n'
                             '  race2.z: {dist: uniform, low: 0.0015, high: 0.003}')
    for z2, lam, phi in zip(table['race2.z'], table['lam_in_op'], table['phi_final_deg']):
        drive = apply_settings(P3, {'z_G': 0.001, 'race2.n': 2, 'race2.z': z2})[0]
        assert lam == pytest.approx(coupled.lam_max_sweep(drive, [OMEGA])[0], rel=1e-9)
        assert len(phi) == 4

"""`abb-sim sweep --serial` and `abb-sim sweep-report` end to end on a small spec."""

import json

import pyarrow.parquet as pq
import pytest

from abb_ros.cli import main
from abb_ros.sweep import store

SPEC = """\
name: cli_test
scenario: p3
parameters:
  eps: {dist: uniform, low: 0.1e-3, high: 0.9e-3}
  n: {dist: grid, values: [2, 3]}
samples: 5
sampling: {method: lhs, seed: 2}
partition_size: 4
compute:
  stability: {wbar: [2.0, 2.7]}
  run: {duration: 0.05, rbar_limit: 2.0e-2}
"""


@pytest.mark.slow
def test_serial_sweep_writes_one_parquet_file_per_partition_with_spec_and_version(
        tmp_path, capsys):
    spec = tmp_path / 'spec.yaml'
    spec.write_text(SPEC)
    out = tmp_path / 'out'
    assert main(['sweep', str(spec), '--out', str(out), '--serial', '--no-progress',
                 '--json']) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary['samples'] == 10 and summary['partitions'] == 3
    assert summary['partitions_computed'] == 3 and summary['workers'] == 0
    files = sorted(p.name for p in out.iterdir())
    assert files == ['_sweep.json', 'part-00000.parquet', 'part-00001.parquet',
                     'part-00002.parquet']
    meta = pq.read_schema(out / 'part-00001.parquet').metadata
    assert json.loads(meta[store.SPEC_KEY])['name'] == 'cli_test'
    assert meta[store.VERSION_KEY].decode() == store.package_version() != 'unknown'
    table = pq.read_table(out / 'part-00002.parquet')
    assert table.column('sample').to_pylist() == [8, 9]
    # eps up to 0.9 mm: beyond two balls' capacity (2 m R / M = 0.9 mm at mbar 0.03) only
    # for some drives; those have no balanced equilibrium and lambda = inf
    t, _ = store.read_results(out)
    exists = t.column('balanced_equilibrium_exists').to_pylist()
    lam = t.column('lam_in_op').to_pylist()
    assert all((lam_i == float('inf')) == (not e) for lam_i, e in zip(lam, exists))
    assert {len(v) for v in t.column('phi_final_deg').to_pylist()} == {2, 3}

    fig = tmp_path / 'fig'
    assert main(['sweep-report', str(out), '--out', str(fig), '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    assert set(report['figures']) == {
        'hist_lambda_op.png', 'hist_final_rbar.png', 'hist_settle_time.png',
        'balanced_vs_eps.png', 'balanced_vs_n.png', 'scatter_eps_n.png'} or set(
        report['figures']) == {
        'hist_lambda_op.png', 'hist_final_rbar.png', 'hist_settle_time.png',
        'balanced_vs_eps.png', 'balanced_vs_n.png', 'scatter_n_eps.png'}
    assert all((fig / f).stat().st_size > 1000 for f in report['figures'])
    full = json.loads((fig / 'summary.json').read_text())
    balanced = t.column('balanced').to_pylist()
    assert full['yield'] == sum(balanced) / 10 and full['samples_planned'] == 10
    assert len(full['worst']) == 10 and set(full['worst'][0]) >= {'sample', 'eps', 'n'}
    assert full['run_status_counts'] == {'ok': 10}


def test_report_of_a_directory_without_results_exits_2(tmp_path, capsys):
    assert main(['sweep-report', str(tmp_path), '--out', str(tmp_path / 'fig')]) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'no part-*.parquet' in err

"""`abb-sim basin` on a real distributed.LocalCluster (2 worker processes, 127.0.0.1), resumed.

The reference is the same starts computed serially in this process: the cluster's
``basin.parquet`` must equal it bit for bit (floats compared as their 64-bit patterns), and a
study interrupted after some partitions and resumed must give the same table as one run
through.
"""

import json

import numpy as np
import pyarrow as pa
import pytest

from abb_ros.basin.spec import BasinSpec
from abb_ros.basin.study import PARTS, read_table, run_basin
from abb_ros.cli import main
from abb_ros.io.files.scenario import load_scenario
from abb_ros.sweep.runner import local_cluster

pytestmark = pytest.mark.slow

ARGS = ['--res', '4x3', '--duration', '0.1', '--partition-size', '3', '--no-progress', '--json']


@pytest.fixture(scope='module')
def client():
    from distributed import Client
    cluster = local_cluster(2, dashboard=False)
    c = Client(cluster)
    try:
        yield c
    finally:
        c.close()
        cluster.close()


def _assert_same(table, reference):
    """Equal column by column, floats bit for bit (NaN patterns included)."""
    assert table.num_rows == reference.num_rows
    assert table.schema.remove_metadata() == reference.schema.remove_metadata()
    for name in reference.column_names:
        a, b = table.column(name).combine_chunks(), reference.column(name).combine_chunks()
        if pa.types.is_floating(a.type):
            assert np.array_equal(a.to_numpy().view(np.uint64), b.to_numpy().view(np.uint64)), \
                name
        else:
            assert a.equals(b), name


def _run(out, capsys, *extra):
    code = main(['basin', '--out', str(out), *ARGS, *extra])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return json.loads(captured.out)


def test_local_cluster_equals_serial_bit_for_bit(tmp_path, client, capsys):
    """The same starts on 2 workers (4 partitions) and in this process give the same table."""
    serial = _run(tmp_path / 'serial', capsys, '--serial')
    cluster = _run(tmp_path / 'cluster', capsys, '--scheduler', client.scheduler.address)
    assert cluster['workers'] == 2 and cluster['partitions_computed'] == 4
    _assert_same(read_table(tmp_path / 'cluster'), read_table(tmp_path / 'serial'))
    for key in ('runs', 'balanced_fraction', 'ci95', 'outcomes', 'floquet'):
        assert cluster[key] == serial[key], key


def test_interrupted_study_resumes_to_the_same_table(tmp_path):
    """Stopped after two partitions and resumed: only the rest is computed, same table."""
    scen = load_scenario('p3')
    scen.duration = 0.1
    spec = BasinSpec(scen, {}, [], 1e-3, 0.5, res=(4, 3), partition_size=3)
    written = []

    def stop_after_two(index):
        written.append(index)
        if len(written) == 2:
            raise KeyboardInterrupt

    out = tmp_path / 'out'
    with pytest.raises(KeyboardInterrupt):
        run_basin(spec, out, on_written=stop_after_two)
    assert not (out / 'basin.parquet').exists()     # nothing partial looks finished
    parts = sorted(p.name for p in (out / PARTS).glob('part-*.parquet'))
    assert len(parts) == 2
    summary = run_basin(spec, out, resume=True)
    assert summary['partitions_resumed'] == 2 and summary['partitions_computed'] == 2
    run_basin(spec, tmp_path / 'whole')
    _assert_same(read_table(out), read_table(tmp_path / 'whole'))
    # another spec cannot resume into the directory
    other = BasinSpec(scen, {}, [], 2e-3, 0.5, res=(4, 3), partition_size=3)
    from abb_ros.sweep.runner import SweepError
    with pytest.raises(SweepError, match='another spec'):
        run_basin(other, out, resume=True)


def test_ctrl_c_then_resume_gives_the_table_of_one_run_through(tmp_path, client, capsys):
    """SIGINT mid-study: exit 130, no basin.parquet; --resume computes only the missing parts."""
    from interrupt import interrupt_after_parts
    out = tmp_path / 'out'
    argv = ['basin', '--res', '6x6', '--duration', '0.3', '--partition-size', '2',
            '--no-progress', '--scheduler', client.scheduler.address]
    code, err = interrupt_after_parts([*argv, '--out', str(out)], out / PARTS, timeout_s=120)
    assert code == 130, err
    assert not (out / 'basin.parquet').exists()
    first = {p.name: p.stat().st_mtime_ns for p in (out / PARTS).glob('part-*.parquet')}
    assert 3 <= len(first) < 18, f'{len(first)} partitions written before the interrupt'
    assert main(argv + ['--out', str(out), '--resume', '--json']) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary['partitions_computed'] == 18 - len(first)
    assert {p.name: p.stat().st_mtime_ns for p in (out / PARTS).glob('part-*.parquet')
            if p.name in first} == first
    assert main(argv + ['--out', str(tmp_path / 'whole'), '--json']) == 0
    capsys.readouterr()
    _assert_same(read_table(out), read_table(tmp_path / 'whole'))

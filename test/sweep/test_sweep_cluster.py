"""`abb-sim sweep` on a real distributed.LocalCluster (2 worker processes, 127.0.0.1).

The reference is the same samples computed serially in this process, in one partition: the
Parquet contents of the cluster's sweep must equal it bit for bit (floats compared as their
64-bit patterns), whatever the partitioning, a worker killed mid-sweep or an interrupted
command resumed.
"""

import dataclasses
import json
import os
import signal

import numpy as np
import pyarrow as pa
import pytest
from interrupt import interrupt_after_parts

from abb_ros.cli import main
from abb_ros.sweep import store
from abb_ros.sweep.compute import compute_partition, warm_up
from abb_ros.sweep.runner import local_cluster, run_sweep
from abb_ros.sweep.sampling import draw_samples
from abb_ros.sweep.spec import load_spec

SPEC = """\
name: cluster_test
scenario: p3
parameters:
  eps: {dist: normal, mean: 0.25e-3, std: 0.05e-3, low: 0.1e-3, high: 0.45e-3}
  k: {dist: uniform, low: 3600, high: 4400}
  c: {dist: uniform, low: 0.3, high: 1.0}
samples: SAMPLES
sampling: {method: sobol, seed: 11}
partition_size: PART
compute:
  stability: {wbar: [2.2, 2.7]}
  run: {duration: DURATION, rbar_limit: 1.0e-2}
"""


def _spec_file(tmp_path, samples=24, part=4, duration=0.05):
    path = tmp_path / 'spec.yaml'
    path.write_text(SPEC.replace('SAMPLES', str(samples)).replace('PART', str(part))
                    .replace('DURATION', str(duration)))
    return path


@pytest.fixture(scope='module')
def client(tmp_path_factory):
    from distributed import Client
    cluster = local_cluster(2, dashboard=False)
    c = Client(cluster)
    try:
        # each worker loads the numba kernels from the disk cache once, before the tests time
        c.run(warm_up, load_spec(_spec_file(tmp_path_factory.mktemp('warm'))))
        yield c
    finally:
        c.close()
        cluster.close()


def _serial_table(spec):
    """All samples computed in this process as one partition."""
    whole = dataclasses.replace(spec, partition_size=spec.total)
    return store.to_table(compute_partition(whole, 0, draw_samples(whole)), whole)


def _assert_same_contents(table, reference):
    """Equal column by column, floats bit for bit; the partition number aside."""
    assert table.num_rows == reference.num_rows
    assert table.schema.remove_metadata() == reference.schema.remove_metadata()
    for name in reference.column_names:
        if name == 'partition':
            continue
        a, b = table.column(name).combine_chunks(), reference.column(name).combine_chunks()
        if pa.types.is_floating(a.type):
            assert np.array_equal(a.to_numpy().view(np.uint64), b.to_numpy().view(np.uint64)), \
                name
        else:
            assert a.equals(b), name


@pytest.mark.slow
def test_local_cluster_matches_serial_bit_for_bit(tmp_path, client):
    spec = load_spec(_spec_file(tmp_path))
    res = run_sweep(spec, tmp_path / 'out', client)
    assert res.computed == list(range(6)) and res.skipped == []
    files = sorted(p.name for p in (tmp_path / 'out').iterdir())
    assert files == ['_sweep.json'] + [f'part-{i:05d}.parquet' for i in range(6)]
    table, info = store.read_results(tmp_path / 'out')
    assert info['spec'] == spec.doc and info['version'] == store.package_version()
    _assert_same_contents(table, _serial_table(spec))


@pytest.mark.slow
def test_killing_a_worker_mid_sweep_loses_nothing(tmp_path, client):
    spec = load_spec(_spec_file(tmp_path, samples=32, part=2, duration=0.2))
    before = client.run(os.getpid)
    killed = []

    def kill_busy_worker(_index):
        if killed:
            return
        busy = [addr for addr, keys in client.processing().items() if keys]
        if busy:
            pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    res = run_sweep(spec, tmp_path / 'out', client, on_written=kill_busy_worker)
    assert killed, 'no worker was busy to kill'
    assert len(res.computed) == spec.partitions == 16
    table, _ = store.read_results(tmp_path / 'out')
    _assert_same_contents(table, _serial_table(spec))
    # the nanny replaced the killed worker: the cluster is whole again for the next test
    client.wait_for_workers(2, timeout=60)
    assert killed[0] in before.values() and killed[0] not in client.run(os.getpid).values()


@pytest.mark.slow
def test_resume_after_interrupting_the_command_recomputes_only_missing_partitions(
        tmp_path, client, capsys):
    path = _spec_file(tmp_path, samples=60, part=2, duration=0.5)
    out = tmp_path / 'out'
    address = client.scheduler.address
    code, err = interrupt_after_parts(['sweep', str(path), '--out', str(out), '--scheduler',
                                       address, '--no-progress'], out)
    assert code == 130, err
    first = {p.name: p.stat().st_mtime_ns for p in out.glob('part-*.parquet')}
    missing = 30 - len(first)
    assert 3 <= len(first) < 30, f'{len(first)} partitions written before the interrupt'
    assert not list(out.glob('.part-*'))
    # a new run without --resume refuses the directory; with it, only the missing partitions
    assert main(['sweep', str(path), '--out', str(out), '--scheduler', address]) == 2
    assert '--resume' in capsys.readouterr().err
    code = main(['sweep', str(path), '--out', str(out), '--scheduler', address, '--resume',
                 '--no-progress', '--json'])
    summary = json.loads(capsys.readouterr().out)
    assert code == 0
    assert summary['partitions_computed'] == missing
    assert summary['partitions_resumed'] == len(first)
    assert {p.name: p.stat().st_mtime_ns for p in out.glob('part-*.parquet')
            if p.name in first} == first
    table, _ = store.read_results(out)
    _assert_same_contents(table, _serial_table(load_spec(path)))
    # a changed spec cannot resume into the directory
    path.write_text(path.read_text().replace('seed: 11', 'seed: 12'))
    assert main(['sweep', str(path), '--out', str(out), '--scheduler', address,
                 '--resume']) == 2
    assert 'another spec' in capsys.readouterr().err

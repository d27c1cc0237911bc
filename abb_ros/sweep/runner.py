"""Run a sweep: draw every sample, cut them into partitions, compute, write as they finish.

With a ``distributed.Client`` every missing partition is one task
(:func:`abb_ros.sweep.compute.compute_partition`); the client writes each result as it
arrives (``as_completed``), so the workers need nothing but this package and never touch the
output directory. A worker that dies takes its tasks with it and the scheduler runs them
again elsewhere. Without a client the partitions are computed in this process, in order
(the reference the tests compare the cluster against).
"""

from __future__ import annotations

import json
import logging
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from abb_ros.sweep import store
from abb_ros.sweep.compute import compute_partition
from abb_ros.sweep.sampling import draw_samples

__all__ = ['SweepResult', 'run_sweep', 'check_out_dir', 'SweepError', 'local_cluster', 'has_bokeh']


class SweepError(Exception):
    """The output directory cannot take this sweep (exit code 2 in the CLI)."""


@dataclass
class SweepResult:
    """What :func:`run_sweep` did: the output directory, counts and partitions, wall time."""

    out_dir: str
    samples: int
    partitions: int
    computed: list        # partition indices computed by this call
    skipped: list         # partitions already on disk (resume)
    wall_time: float      # [s]


def _slice(samples: dict, start: int, stop: int) -> dict:
    return {k: v[start:stop] for k, v in samples.items()}


def held_work(out_dir, resume: bool, work: str = 'sweep') -> tuple[Path, bool]:
    """Return (the output directory, whether it holds ``work`` to resume).

    An absent or empty directory takes new work; one holding anything takes only ``--resume``
    (SweepError says why not), whose caller then checks what it holds.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise SweepError(f'--out {out}: exists and is not a directory')
    if not (out.exists() and any(out.iterdir())):
        return out, False
    if not resume:
        raise SweepError(f'--out {out}: exists and is not empty (pass --resume to finish '
                         f'the {work} it holds, or choose a new directory)')
    return out, True


def check_out_dir(spec, out_dir, resume: bool) -> Path:
    """Return the output directory, if it can take this sweep (SweepError says why not)."""
    out, held = held_work(out_dir, resume)
    if held:
        try:
            manifest = store.read_manifest(out)
        except store.SweepFileError as exc:
            raise SweepError(f'--resume: {exc}; no sweep to resume') from None
        if manifest is None:
            raise SweepError(f'--out {out}: holds no {store.MANIFEST}, so no sweep to resume')
        held = json.dumps(manifest.get('spec'), sort_keys=True, separators=(',', ':'))
        if held != store.spec_json(spec):
            raise SweepError(f'--resume: {out} holds a sweep of another spec (its spec is in '
                             f'{out / store.MANIFEST}); the spec must be unchanged to resume')
        try:
            store.check_parts(out, spec)
        except store.SweepFileError as exc:
            raise SweepError(f'--resume: {exc}') from None
    return out


def prepare_out_dir(spec, out_dir, resume: bool) -> Path:
    """Check and create the output directory; returns it."""
    out = check_out_dir(spec, out_dir, resume)
    out.mkdir(parents=True, exist_ok=True)
    store.remove_temporaries(out)
    if store.read_manifest(out) is None:
        store.write_manifest(out, spec, spec.partitions)
    return out


def run_sweep(spec, out_dir, client=None, resume: bool = False, progress=None,
              on_written=None, compute=compute_partition, samples=None) -> SweepResult:
    """Compute the partitions of ``spec`` that ``out_dir`` lacks and write them.

    client : distributed.Client or None (in-process); progress(k): called with the number of
    samples of each partition written; on_written(index): called after each partition is
    written (tests use it to interrupt or kill a worker). ``compute(spec, index, columns)``
    computes one partition and ``samples`` are all the drawn columns (default: a sweep's,
    :func:`draw_samples`; a basin study passes its own, docs/basin.md).
    """
    t0 = time.perf_counter()
    out = prepare_out_dir(spec, out_dir, resume)
    samples = draw_samples(spec) if samples is None else samples
    done = store.finished_partitions(out, spec.partitions)
    todo = [i for i in range(spec.partitions) if i not in done]
    if progress is not None and done:
        progress(sum(_count(spec, i) for i in done))

    def written(index, result):
        store.write_partition(out, index, result, spec)
        if progress is not None:
            progress(_count(spec, index))
        if on_written is not None:
            on_written(index)

    if client is None:
        for i in todo:
            written(i, compute(spec, i, _slice(samples, *spec.partition_bounds(i))))
    else:
        from distributed import as_completed
        # unique per call: a result another client left on a shared cluster is never reused
        token = uuid.uuid4().hex[:12]
        futures = {client.submit(compute, spec, i,
                                 _slice(samples, *spec.partition_bounds(i)),
                                 key=f'abb-sweep-{token}-{i:05d}', retries=2): i
                   for i in todo}
        try:
            for fut in as_completed(futures):
                written(futures[fut], fut.result())
                fut.release()
        finally:
            for fut in futures:
                if not fut.done():
                    fut.cancel()
    return SweepResult(str(out), spec.total, spec.partitions, todo, sorted(done),
                       time.perf_counter() - t0)


def _count(spec, index):
    start, stop = spec.partition_bounds(index)
    return stop - start


def local_cluster(workers: int, dashboard: bool = False):
    """Start a distributed.LocalCluster on this machine.

    ``workers`` processes with one thread each, bound to 127.0.0.1, their logs below CRITICAL
    kept off stderr: a stop's 'worker still alive, killing' and the heartbeat errors of workers
    outliving their scheduler are no errors of the sweep (a task's own exception reaches the
    client through its future). The
    scheduler's HTTP server listens on a free port (never a fixed one that another cluster may
    hold); the dashboard is on it when asked and bokeh is installed.
    """
    from distributed import LocalCluster
    return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                        host='127.0.0.1', dashboard_address='127.0.0.1:0',
                        scheduler_kwargs={'dashboard': bool(dashboard) and has_bokeh()},
                        silence_logs=logging.CRITICAL)


def has_bokeh() -> bool:
    """Return whether bokeh is installed, so that a scheduler serves the Dask dashboard."""
    import importlib.util
    return importlib.util.find_spec('bokeh') is not None

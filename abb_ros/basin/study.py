"""Run a basin study into a directory: partitions on Dask, then the table, summary and picture.

``DIR/parts/`` holds the partitions as the sweep store writes them (one Parquet file each,
written under a temporary name and renamed, with the spec in ``DIR/parts/_sweep.json``), so
an interrupted study resumes where it stopped (:func:`abb_ros.sweep.runner.run_sweep` does
the scheduling for both). When every partition is in, ``DIR/basin.parquet`` (one row per
start, sorted by start), ``DIR/basin.json`` (the summary) and ``DIR/basin.png`` (the picture)
are written, each under a temporary name and renamed, so a file with its final name is
complete.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from abb_ros.basin.compute import compute_partition
from abb_ros.basin.summary import floquet_verdict, fraction_summary, operating_omega
from abb_ros.sweep import store
from abb_ros.sweep.runner import SweepError, check_out_dir, held_work, run_sweep

__all__ = ['PARTS', 'TABLE', 'SUMMARY', 'PICTURE', 'check_out', 'run_basin', 'read_table']

PARTS = 'parts'
TABLE = 'basin.parquet'
SUMMARY = 'basin.json'
PICTURE = 'basin.png'


def check_out(spec, out_dir, resume: bool) -> Path:
    """Return the output directory, if it can take this study (SweepError says why not)."""
    out, held = held_work(out_dir, resume, 'basin study')
    if held:
        if not (out / PARTS).is_dir():
            raise SweepError(f'--out {out}: holds no {PARTS}/, so no basin study to resume')
        check_out_dir(spec, out / PARTS, True)
    return out


def run_basin(spec, out_dir, client=None, resume: bool = False, progress=None,
              on_written=None) -> dict:
    """Compute the study's missing partitions, then write its table, summary and picture.

    Returns the summary (:func:`summarise`) with ``partitions_computed``,
    ``partitions_resumed`` and ``wall_time_s`` of this call.
    """
    out = check_out(spec, out_dir, resume)
    out.mkdir(parents=True, exist_ok=True)
    result = run_sweep(spec, out / PARTS, client, resume=resume, progress=progress,
                       on_written=on_written, compute=compute_partition, samples=spec.draw())
    table, _ = store.read_results(out / PARTS)
    table = table.drop_columns(['partition'])
    summary = summarise(spec, table)
    _write_table(out / TABLE, table, spec)
    _write_text(out / SUMMARY, json.dumps(summary, indent=1, sort_keys=True) + '\n')
    from abb_ros.plots.basin import basin_picture
    tmp = out / f'.{PICTURE}.tmp-{os.getpid()}.png'
    basin_picture(spec, table, summary, tmp)
    os.replace(tmp, out / PICTURE)
    return {**summary, 'partitions': result.partitions,
            'partitions_computed': len(result.computed),
            'partitions_resumed': len(result.skipped),
            'wall_time_s': round(result.wall_time, 3)}


def summarise(spec, table) -> dict:
    """Return the study's summary: fraction, interval, classes, Floquet verdict, integrator."""
    outcomes = table.column('outcome').to_pylist()
    omega, source = operating_omega(spec.scenario, table.column('omega_final').to_numpy())
    floquet = floquet_verdict(spec.scenario.params, omega)
    floquet['operating_speed'] = source
    frac = fraction_summary(outcomes)
    return {'scenario': spec.scenario.name, 'n': spec.n, 'starts': spec.total,
            'sampler': spec.sampler, 'duration_s': spec.scenario.duration,
            'integrator': spec.integrator, 'dt_s': spec.options.get('dt', _default_dt()),
            'rbar_limit': spec.rbar_limit, 'rest_tol_deg': spec.rest_tol_deg,
            **frac, 'floquet_balanced': floquet['balanced'], 'floquet': floquet}


def _default_dt() -> float:
    from abb_ros.model.dynamics.integrate import DEFAULT_DT
    return DEFAULT_DT


def _write_text(path: Path, text: str) -> None:
    tmp = path.with_name(f'.{path.name}.tmp-{os.getpid()}')
    tmp.write_text(text, encoding='utf-8')
    os.replace(tmp, path)


def _write_table(path: Path, table, spec) -> None:
    import pyarrow.parquet as pq
    meta = {store.SPEC_KEY: store.spec_json(spec).encode(),
            store.VERSION_KEY: store.package_version().encode()}
    tmp = path.with_name(f'.{path.name}.tmp-{os.getpid()}')
    pq.write_table(table.replace_schema_metadata(meta), tmp)
    os.replace(tmp, path)


def read_table(out_dir):
    """Return the study's table (``DIR/basin.parquet``) as a pyarrow Table."""
    import pyarrow.parquet as pq
    return pq.read_table(Path(out_dir) / TABLE)

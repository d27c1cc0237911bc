"""The results of a sweep on disk: a Parquet dataset, one file per partition.

``DIR/part-00012.parquet`` holds partition 12. Each file is written to a temporary name in
the same directory and renamed into place (``os.replace``, atomic on POSIX), so a file with
the final name is always complete: an interrupted sweep loses at most the partitions it was
computing, and ``--resume`` recomputes exactly the partitions whose file is missing. Every
file carries the normalised spec (JSON) and the package version in its Parquet key-value
metadata (``abb_ros.spec``, ``abb_ros.version``); ``DIR/_sweep.json`` holds the same, written
when the sweep starts (readers of the dataset skip names starting with ``_`` and ``.``).
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np

__all__ = ['package_version', 'spec_json', 'part_path', 'write_partition', 'finished_partitions',
           'read_results', 'read_manifest', 'SweepFileError', 'check_parts', 'write_manifest',
           'MANIFEST', 'SPEC_KEY',
           'VERSION_KEY']

MANIFEST = '_sweep.json'
SPEC_KEY = b'abb_ros.spec'
VERSION_KEY = b'abb_ros.version'
_PART = re.compile(r'^part-(\d{5,})\.parquet$')


def package_version() -> str:
    """Return the installed abb_ros version ('unknown' from a source tree)."""
    try:
        from importlib.metadata import version
        return version('abb_ros')
    except Exception:  # noqa: BLE001 - not installed (source tree on sys.path)
        return 'unknown'


def spec_json(spec) -> str:
    """Return the normalised spec as canonical JSON (what resume compares)."""
    return json.dumps(spec.doc, sort_keys=True, separators=(',', ':'))


def part_path(out_dir, index: int) -> Path:
    """Return the Parquet file of partition ``index`` in ``out_dir``."""
    return Path(out_dir) / f'part-{index:05d}.parquet'


def _atomic_write_bytes(path: Path, data: bytes) -> None:
    tmp = path.with_name(f'.{path.name}.tmp-{os.getpid()}')
    with open(tmp, 'wb') as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def write_manifest(out_dir, spec, partitions: int) -> None:
    """Write the sweep's manifest (spec, version, partition and sample counts) atomically."""
    doc = {'spec': spec.doc, 'version': package_version(), 'partitions': partitions,
           'samples': spec.total}
    _atomic_write_bytes(Path(out_dir) / MANIFEST,
                        (json.dumps(doc, indent=1, sort_keys=True) + '\n').encode())


class SweepFileError(ValueError):
    """A file of a sweep directory that is not what abb-sim sweep writes (names the file)."""


def read_manifest(out_dir) -> dict | None:
    """Return the manifest of the sweep in ``out_dir``, or None without one.

    Raises SweepFileError for a manifest that is not a JSON object with a spec.
    """
    path = Path(out_dir) / MANIFEST
    if not path.exists():
        return None
    try:
        with open(path, encoding='utf-8') as f:
            doc = json.load(f)
    except (ValueError, UnicodeDecodeError) as exc:
        raise SweepFileError(f'{path}: not a sweep manifest (not JSON: {exc})') from None
    if not isinstance(doc, dict) or not isinstance(doc.get('spec'), dict):
        raise SweepFileError(f'{path}: not a sweep manifest (a JSON object with a spec)')
    return doc


def to_table(result: dict, spec):
    """Return the partition's columns as a pyarrow Table, the spec and version as metadata."""
    import pyarrow as pa
    arrays = {}
    for name, values in result.items():
        if name == 'phi_final_deg':
            lengths = np.array([len(v) for v in values], dtype=np.int32)
            offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int32)
            flat = np.concatenate(values) if len(values) else np.zeros(0)
            arrays[name] = pa.ListArray.from_arrays(pa.array(offsets),
                                                    pa.array(flat, pa.float64()))
        elif isinstance(values, np.ndarray) and values.dtype == object:
            arrays[name] = pa.array(list(values), pa.string())
        else:
            arrays[name] = pa.array(np.asarray(values))
    table = pa.table(arrays)
    meta = {SPEC_KEY: spec_json(spec).encode(), VERSION_KEY: package_version().encode()}
    return table.replace_schema_metadata(meta)


def write_partition(out_dir, index: int, result: dict, spec) -> Path:
    """Write partition ``index`` atomically (temporary name, then rename)."""
    import pyarrow.parquet as pq
    path = part_path(out_dir, index)
    tmp = path.with_name(f'.{path.name}.tmp-{os.getpid()}')
    pq.write_table(to_table(result, spec), tmp)
    os.replace(tmp, path)
    return path


def finished_partitions(out_dir, count: int) -> set:
    """Return the indices < count whose file exists and holds a readable Parquet footer."""
    import pyarrow.parquet as pq
    done = set()
    for entry in os.listdir(out_dir):
        m = _PART.match(entry)
        if not m or int(m.group(1)) >= count:
            continue
        try:
            pq.read_metadata(Path(out_dir) / entry)
        except Exception:  # noqa: BLE001 - unreadable: compute it again
            continue
        done.add(int(m.group(1)))
    return done


def check_parts(out_dir, spec) -> None:
    """Refuse, before a resume computes anything, part files that are not of ``spec``.

    Each part file with a readable footer (an unreadable one is computed again) must carry
    this sweep's spec, hold its own partition (the ``partition`` column) and no sample that
    another part holds. Raises SweepFileError naming the file.
    """
    import pyarrow.parquet as pq
    expected = spec_json(spec).encode()
    seen: dict[int, str] = {}
    for path in sorted(p for p in Path(out_dir).iterdir() if _PART.match(p.name)):
        index = int(_PART.match(path.name).group(1))
        try:
            meta = pq.read_metadata(path)
        except Exception:  # noqa: BLE001 - unreadable: computed again, as finished_partitions
            continue
        if (meta.metadata or {}).get(SPEC_KEY) != expected:
            raise SweepFileError(f'{path}: a part of another sweep (its {SPEC_KEY.decode()} '
                                 f'is not the spec of {Path(out_dir) / MANIFEST}); remove it to '
                                 'resume')
        table = _read_part(pq, path)
        if 'partition' in table.column_names:
            held = set(table.column('partition').to_pylist())
            if held != {index}:
                raise SweepFileError(f'{path}: holds partition {sorted(held)[0]}, not '
                                     f'{index} (a part copied or renamed); remove it to resume')
        for sample in table.column('sample').to_pylist():
            if sample in seen:
                raise SweepFileError(f'{path}: sample {sample} is also in {seen[sample]} (a '
                                     'part copied in twice); remove it to resume')
            seen[sample] = path.name


def remove_temporaries(out_dir) -> None:
    """Remove the temporary files left by an interrupted writer."""
    for entry in os.listdir(out_dir):
        if entry.startswith('.part-') and '.tmp-' in entry:
            os.remove(Path(out_dir) / entry)


def _read_part(pq, path):
    """Read one part file; SweepFileError names a file that is not a part of a sweep."""
    import pyarrow as pa
    try:
        table = pq.read_table(path)
    except (pa.ArrowException, OSError, ValueError) as exc:
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SweepFileError(f'{path}: not a readable Parquet file ({why})') from None
    meta = table.schema.metadata or {}
    if SPEC_KEY not in meta or 'sample' not in table.column_names:
        raise SweepFileError(f'{path}: a Parquet file, but not a part of an abb-sim sweep (no '
                             f'{SPEC_KEY.decode()} metadata or sample column)')
    try:
        json.loads(meta[SPEC_KEY])
    except ValueError:
        raise SweepFileError(f'{path}: its {SPEC_KEY.decode()} metadata is not JSON') from None
    return table


def _check_same_sweep(first: Path, first_table, path: Path, table) -> None:
    """Refuse a part file of another sweep, or of other columns, beside ``first`` (one line).

    The sweep's identity is its spec (the metadata every part carries): a part of another
    sweep with the same columns would otherwise be counted in this one's samples.
    """
    if table.schema.metadata.get(SPEC_KEY) != first_table.schema.metadata.get(SPEC_KEY):
        raise SweepFileError(f'{path}: a part of another sweep (its spec differs from that of '
                             f'{first.name})')
    names, expected = table.column_names, first_table.column_names
    if names != expected:
        extra = [n for n in names if n not in expected]
        missing = [n for n in expected if n not in names]
        raise SweepFileError(f'{path}: its columns differ from those of {first.name} (extra: '
                             f'{", ".join(extra) or "none"}; missing: '
                             f'{", ".join(missing) or "none"})')


def read_results(out_dir):
    """Read all finished partitions as one pyarrow Table sorted by sample.

    Returns the table and the metadata of the first file ({'spec': dict, 'version': str});
    raises FileNotFoundError without any and SweepFileError for a file that is not a part.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq
    files = sorted(p for p in Path(out_dir).iterdir() if _PART.match(p.name))
    if not files:
        raise FileNotFoundError(f'no part-*.parquet files in {out_dir}')
    tables = [_read_part(pq, p) for p in files]
    meta = tables[0].schema.metadata or {}
    for path, t in zip(files[1:], tables[1:]):
        _check_same_sweep(files[0], tables[0], path, t)
    try:
        table = pa.concat_tables([t.replace_schema_metadata(None) for t in tables])
    except pa.ArrowException as exc:
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SweepFileError(f'{out_dir}: its part files do not hold one sweep ({why})'
                             ) from None
    table = table.sort_by('sample')
    samples = table.column('sample').to_numpy()
    repeated = samples[1:][samples[1:] == samples[:-1]]
    if repeated.size:
        raise SweepFileError(f'{out_dir}: sample {int(repeated[0])} is in two part files (a part '
                             'copied in twice)')
    info = {'spec': json.loads(meta.get(SPEC_KEY, b'{}')),
            'version': meta.get(VERSION_KEY, b'unknown').decode()}
    return table, info

"""rosbag2 MCAP bags: reading what :mod:`abb_ros.io.bag.writer` (or rosbag2) wrote."""

from __future__ import annotations

import json
import os
from pathlib import Path

from mcap.exceptions import EndOfFile, McapError
from mcap.records import Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from abb_ros.io.bag.writer import DRIVE_METADATA, STORAGE_ID, BagError, topic_name
from abb_ros.io.files.safe_yaml import YamlFileError, load_file
from abb_ros.io.wire import msgdefs

METADATA_MAX_BYTES = 1 << 20
"""Largest metadata.yaml read [bytes]; rosbag2 lists every file and topic in it, some 200 bytes
each (safe_yaml.MAX_BYTES gives the parse time)."""


def bag_files(path) -> list[Path]:
    """Return the MCAP files of a bag directory (per its metadata.yaml) or a single .mcap."""
    path = Path(path)
    if path.is_file():
        return [path]
    if not path.is_dir():
        raise BagError(f'{path} does not exist')
    meta = path / 'metadata.yaml'
    if meta.exists():
        try:
            info = load_file(meta, METADATA_MAX_BYTES)['rosbag2_bagfile_information']
            storage = info.get('storage_identifier', STORAGE_ID)
            names = [Path(p).name for p in info['relative_file_paths']]
        except YamlFileError as exc:
            raise BagError(f'{meta} is not rosbag2 metadata: {exc.why}') from None
        except (KeyError, TypeError, AttributeError) as exc:
            raise BagError(f'{meta} is not rosbag2 metadata (no {exc})') from None
        if storage != STORAGE_ID:
            raise BagError(f'{path} is a {storage!r} bag; only MCAP bags can be read')
        files = [path / n for n in names]
    else:
        files = sorted(path.glob('*.mcap'))
    missing = [str(f) for f in files if not f.exists()]
    if missing or not files:
        raise BagError(f'{path}: no MCAP file found' + (f' ({missing[0]})' if missing else ''))
    return files


def iter_records(path, emit_chunks: bool = False):
    """Yield the MCAP records of a bag in file order; a truncated last chunk ends the stream."""
    for file in bag_files(path):
        with open(file, 'rb') as stream:
            reader = StreamReader(stream, emit_chunks=emit_chunks, validate_crcs=True)
            try:
                yield from reader.records
            except EndOfFile:
                pass
            except McapError as exc:
                raise BagError(f'{file}: {exc}') from exc


def iter_raw(path, topics=None):
    """Yield (topic, type_name, cdr_bytes, log_time_ns) for the messages of a bag."""
    wanted = None if topics is None else {topic_name(t) for t in topics}
    schemas: dict[int, str] = {}
    channels: dict[int, tuple[str, str]] = {}
    for record in iter_records(path):
        if isinstance(record, Message):
            topic, type_name = channels.get(record.channel_id, (None, None))
            if topic is not None and (wanted is None or topic in wanted):
                yield topic, type_name, record.data, record.log_time
        elif isinstance(record, Channel):
            if record.message_encoding != 'cdr' and (wanted is None or record.topic in wanted):
                raise BagError(f'{path}: topic {record.topic} is encoded as '
                               f'{record.message_encoding!r}; only CDR (rosbag2) bags can be read')
            channels[record.id] = (record.topic, schemas.get(record.schema_id, ''))
        elif isinstance(record, Schema):
            schemas[record.id] = record.name


def read_bag(path, topics=None):
    """Yield (topic, rclpy message, log_time_ns) for the messages of a bag, in file order."""
    from rclpy.serialization import deserialize_message
    for topic, type_name, data, log_time in iter_raw(path, topics):
        try:
            cls = msgdefs.message_class(type_name)
            msg = deserialize_message(data, cls)
        except msgdefs.MessageTypeError as exc:
            raise BagError(f'{path}: topic {topic}: {exc}') from None
        except Exception as exc:  # noqa: BLE001 - rclpy raises several types on bad bytes
            raise BagError(f'{path}: topic {topic}: a message is not valid CDR for '
                           f'{type_name} ({type(exc).__name__})') from None
        yield topic, msg, log_time


def read_metadata(path) -> dict[str, dict[str, str]]:
    """Return the MCAP metadata records of a bag by name (the last record of a name wins)."""
    found: dict[str, dict[str, str]] = {}
    for record in iter_records(path, emit_chunks=True):
        if isinstance(record, Metadata):
            found[record.name] = dict(record.metadata)
    return found


def read_drive_params(path) -> dict | None:
    """Return the drive parameters (SI) that the writer stored, or None."""
    record = read_metadata(path).get(DRIVE_METADATA)
    if not record or 'drive_params' not in record:
        return None
    try:
        return json.loads(record['drive_params'])
    except ValueError:
        raise BagError(f'{path}: the stored drive parameters are not JSON') from None


def is_finished(path) -> bool:
    """Return whether every MCAP file of the bag ends in a footer and magic (closed cleanly)."""
    for file in bag_files(path):
        with open(file, 'rb') as f:
            f.seek(0, os.SEEK_END)
            if f.tell() < 45:
                return False
            f.seek(-8, os.SEEK_END)
            if f.read(8) != b'\x89MCAP0\r\n':
                return False
    return True



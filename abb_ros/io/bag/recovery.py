"""Finishing a bag whose writer died, in place (what ``ros2 bag reindex`` does)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from mcap.records import Channel, Message, Metadata, Schema

from abb_ros.io.bag.reader import bag_files, iter_records
from abb_ros.io.bag.writer import DRIVE_METADATA, BagWriter
from abb_ros.io.files.safe_yaml import load_text


def recover(path) -> int:
    """Finish a bag whose writer died (SIGKILL, power loss, full disk), in place.

    Keeps every message up to the last complete chunk, adds the summary, the 'rosbag2'
    metadata record and the final ``metadata.yaml`` (what ``ros2 bag reindex`` does for a
    rosbag2 bag), so that readers which need a summary (rosbags, ``ros2 bag info``) open it.
    Returns the number of messages kept.
    """
    path = Path(path)
    work = path.parent / f'.{path.name}.recovering'
    if work.exists():
        shutil.rmtree(work)
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    with BagWriter(work / path.name) as out:
        for record in iter_records(path):
            if isinstance(record, Message) and record.channel_id in channels:
                channel = channels[record.channel_id]
                out.write(channel.topic, record.data, record.log_time, record.publish_time)
            elif isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
                qos = load_text(record.metadata.get('offered_qos_profiles') or '[]',
                                f'{record.topic} offered_qos_profiles')
                out.add_topic(record.topic, schemas[record.schema_id].name, qos=qos or None,
                              type_hash=record.metadata.get('topic_type_hash'))
            elif isinstance(record, Metadata) and record.name == DRIVE_METADATA:
                out.set_drive_params(json.loads(record.metadata['drive_params']))
            elif isinstance(record, Metadata) and record.name != 'rosbag2':
                out.add_metadata(record.name, record.metadata)
        kept = out.message_count
    old = bag_files(path)
    for file in old + sorted(path.glob('*.tmp')):   # and the dead writer's metadata reserve
        file.unlink()
    for item in (work / path.name).iterdir():
        os.replace(item, path / item.name)
    shutil.rmtree(work)
    return kept

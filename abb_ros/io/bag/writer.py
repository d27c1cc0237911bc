"""rosbag2-compatible MCAP bags (ROS 2 Jazzy, metadata version 9): the writer.

A bag is a directory holding ``metadata.yaml`` and ``<dirname>_0.mcap``, laid out as Jazzy's
``rosbag2_storage_mcap`` writes it: profile ``ros2``; one schema per message type, encoding
``ros2msg`` with the full definition text (:mod:`abb_ros.io.wire.msgdefs`); one channel per topic,
encoding ``cdr``, with channel metadata ``offered_qos_profiles`` (YAML text, metadata v9 policy
names) and ``topic_type_hash`` (RIHS01); at close a metadata record ``rosbag2`` whose key
``serialized_metadata`` is the bag metadata as YAML (``ros_distro: jazzy``). The drive
parameters go into a metadata record ``abb_ros`` (key ``drive_params``, JSON, SI) and into
``custom_data`` of ``metadata.yaml``, beside ``abb_ros.writer`` (this writer made the bag).
Reading is :mod:`abb_ros.io.bag.reader`, finishing a
bag whose writer died is :mod:`abb_ros.io.bag.recovery`.

Crash safety: messages are grouped into zstd-compressed chunks written whole to the OS when a
chunk is full and at least every ``flush_period`` seconds; ``metadata.yaml`` is written at open
and whenever a topic is added, so a killed recording is a readable bag (without summary) up to
its last complete chunk. A write that the disk refuses (``ENOSPC``) cuts the file back to its
last whole record and raises :class:`BagWriteError`. ``metadata.yaml`` counts only the messages
of chunks that reached the file, so it never claims more than the file holds; after a write
error its ``custom_data`` says ``abb_ros.incomplete`` and why. So that this last metadata.yaml
can still be written on a full disk, the writer keeps a reserve file (``metadata.reserve.tmp``,
twice the metadata's size) that it deletes first when a write fails, and at close.
"""

from __future__ import annotations

import dataclasses
import errno
import json
import os
import shutil
from pathlib import Path

from abb_ros.io.bag.mcap_file import McapFile
from abb_ros.io.bag.metadata import default_qos, dump_yaml, qos_dict
from abb_ros.io.wire import msgdefs

METADATA_VERSION = 9
ROS_DISTRO = 'jazzy'
STORAGE_ID = 'mcap'
PROFILE = 'ros2'
LIBRARY = 'abb_ros rosbag2-compatible writer (mcap python)'
DEFAULT_CHUNK_SIZE = 768 * 1024  # the MCAP C++ writer's default, as rosbag2 uses it [bytes]
DEFAULT_FLUSH_PERIOD = 1.0  # a chunk in progress is written at least this often [s]
DRIVE_METADATA = 'abb_ros'
INCOMPLETE_KEY = 'abb_ros.incomplete'
"""custom_data key of metadata.yaml marking a bag cut short (its value says why)."""
WRITER_KEY = 'abb_ros.writer'
"""custom_data key of metadata.yaml naming this writer (:data:`LIBRARY`) in every bag it
writes: what ``abb-sim run --overwrite`` asks before it replaces a directory."""
_CHUNK_OPCODE = 0x06   # MCAP record opcode of a Chunk
_RESERVE = 'metadata.reserve.tmp'
_MIN_RESERVE = 8192    # [bytes]
_COMPRESSION = {'zstd': 'zstd', 'lz4': 'lz4', 'none': ''}   # the MCAP chunk compression names


class BagError(Exception):
    """Bad use of a bag: the path exists, an unknown topic, not a bag, a closed writer."""


class BagExistsError(BagError):
    """The bag's directory exists and ``overwrite`` was not given."""


class BagWriteError(OSError):
    """The disk refused a write (e.g. ENOSPC). The bag is closed and readable up to there."""


def topic_name(name: str) -> str:
    """Return the topic ``name`` fully qualified, as rosbag2 records topic names."""
    if not name:
        raise BagError('empty topic name')
    return name if name.startswith('/') else '/' + name


class _FileSink:
    """An unbuffered file for the MCAP writer.

    Every write reaches the OS whole or raises; ``good`` is the end of the last whole write,
    which is a record boundary, so :meth:`cut` drops a record that was half written.
    ``on_chunk`` is called after a Chunk record reached the OS whole.
    """

    def __init__(self, path: Path, opener=None, on_chunk=None):
        self._raw = (opener or _open_new)(path)
        self.good = 0
        self._on_chunk = on_chunk

    def write(self, data) -> int:
        view = memoryview(data)
        done = 0
        while done < len(view):
            n = self._raw.write(view[done:])
            if not n:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            done += n
        self.good += done
        if done and view[0] == _CHUNK_OPCODE and self._on_chunk is not None:
            self._on_chunk()
        return done

    def tell(self) -> int:
        return self.good

    def flush(self) -> None:
        """Do nothing: writes are unbuffered."""

    def cut(self) -> None:
        try:
            self._raw.truncate(self.good)
        except OSError:
            pass

    def close(self) -> None:
        self._raw.close()


def _open_new(path: Path):
    return open(path, 'xb', buffering=0)


@dataclasses.dataclass(slots=True)
class _Topic:
    name: str
    type: str
    channel_id: int
    qos: list
    type_hash: str
    count: int = 0      # messages given to the MCAP writer
    durable: int = 0    # of those, in chunks that reached the file


def _prepare_directory(path: Path, overwrite: bool) -> None:
    if path.exists() or path.is_symlink():
        if not overwrite:
            raise BagExistsError(f'{path} exists; choose another output or pass overwrite=True')
        if not path.is_dir():
            raise BagError(f'{path} exists and is not a bag directory; not overwriting it')
        strangers = [p.name for p in path.iterdir()
                     if p.name != 'metadata.yaml' and p.suffix not in ('.mcap', '.tmp')]
        if strangers:
            raise BagError(f'{path} holds files that are not part of a bag ({strangers[0]}); '
                           'not overwriting it')
        shutil.rmtree(path)
    path.mkdir(parents=True)


class BagWriter:
    """Write a rosbag2 (Jazzy) MCAP bag directory.

    ``with BagWriter(path) as bag: bag.add_topic('joint_states', 'sensor_msgs/msg/JointState');
    bag.write('joint_states', cdr_bytes, log_time_ns)``. Messages are their CDR bytes, as a
    raw subscription delivers them or :mod:`abb_ros.io.wire.cdr` encodes them.
    """

    def __init__(self, path, overwrite: bool = False, chunk_size: int = DEFAULT_CHUNK_SIZE,
                 compression: str = 'zstd', flush_period: float = DEFAULT_FLUSH_PERIOD,
                 opener=None):
        if compression not in _COMPRESSION:
            raise BagError(f'compression must be one of {", ".join(_COMPRESSION)}, '
                           f'got {compression!r}')
        if not chunk_size > 0:
            raise BagError(f'chunk_size must be > 0 bytes, got {chunk_size!r}')
        self.path = Path(path)
        self._reserved = 0
        _prepare_directory(self.path, overwrite)
        self.mcap_path = self.path / f'{self.path.name}_0.mcap'
        self._sink = _FileSink(self.mcap_path, opener, self._chunk_written)
        self._mcap = McapFile(self._sink, chunk_size, _COMPRESSION[compression],
                              flush_period=flush_period, resolve=self._checked,
                              on_error=self._fail)
        # the MCAP file's methods themselves: one call less per message
        self.write, self.write_many = self._mcap.write, self._mcap.write_many
        self._topics: dict[str, _Topic] = {}
        self._schemas: dict[str, int] = {}
        self._custom: dict[str, str] = {WRITER_KEY: LIBRARY}
        self._durable_span: tuple[int, int] | None = None   # (start, end) of durable messages
        self.durable_count = 0
        self.closed = False
        self.error: OSError | None = None
        self._guard(self._mcap.start, profile=PROFILE, library=LIBRARY)
        self._write_metadata_yaml()

    def __enter__(self) -> 'BagWriter':
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def message_count(self) -> int:
        """Messages given so far."""
        return sum(t.count for t in self._topics.values())

    @property
    def topics(self) -> dict[str, str]:
        """Topic name -> message type of the topics added so far."""
        return {t.name: t.type for t in self._topics.values()}

    def has_topic(self, name: str) -> bool:
        """Return whether the topic ``name`` (as :meth:`add_topic` was given it) was added."""
        return name in self._topics or topic_name(name) in self._topics

    def add_topic(self, name: str, type_name: str, qos=None, type_hash: str | None = None
                  ) -> None:
        """Add a topic. ``qos``: rclpy QoSProfile(s) or dicts offered by its publishers."""
        self._check_open()
        name = topic_name(name)
        type_name = msgdefs.normalize_type(type_name)
        if name in self._topics:
            if self._topics[name].type != type_name:
                raise BagError(f'topic {name} was added as {self._topics[name].type}, '
                               f'not {type_name}')
            return
        profiles = [default_qos()] if qos is None else (
            [qos] if not isinstance(qos, (list, tuple)) else list(qos))
        profiles = [qos_dict(p) for p in profiles]
        digest = msgdefs.type_hash(type_name) if type_hash is None else type_hash
        schema_id = self._schemas.get(type_name)
        if schema_id is None:
            text = msgdefs.full_text(type_name)
            schema_id = self._guard(self._mcap.register_schema, name=type_name,
                                    encoding='ros2msg', data=text.encode())
            self._schemas[type_name] = schema_id
        channel_id = self._guard(
            self._mcap.register_channel, topic=name, message_encoding='cdr',
            schema_id=schema_id, metadata={'offered_qos_profiles': dump_yaml(profiles),
                                           'topic_type_hash': digest})
        entry = self._topics[name] = _Topic(name, type_name, channel_id, profiles, digest)
        self._mcap.channels[name] = self._mcap.channels[name.lstrip('/')] = entry
        self._write_metadata_yaml()

    def write(self, topic: str, message, log_time_ns: int, publish_time_ns: int | None = None
              ) -> None:
        """Append one message (its CDR bytes) received at ``log_time_ns``."""
        self._mcap.write(topic, message, log_time_ns, publish_time_ns)

    def write_many(self, messages, log_time_ns: int) -> None:
        """Append several messages received at ``log_time_ns``, e.g. one sample's.

        ``messages``: (topic, CDR bytes) pairs, as :func:`abb_ros.io.wire.cdr.sample_cdr` gives
        them; the same as :meth:`write` for each in turn.
        """
        self._mcap.write_many(messages, log_time_ns)

    def _checked(self, topic: str, message) -> tuple[_Topic, bytes]:
        """Return the topic entry and the bytes of ``message``, or raise what is wrong."""
        self._check_open()
        entry = self._topics.get(topic) or self._topics.get(topic_name(topic))
        if entry is None:
            raise BagError(f'topic {topic!r} was not added to the bag (call add_topic first)')
        if not isinstance(message, (bytes, bytearray, memoryview)):
            raise BagError(f'topic {entry.name}: write() takes the CDR bytes of a message '
                           f'(as a raw subscription delivers them), got a '
                           f'{type(message).__name__}')
        return entry, bytes(message)

    def _chunk_written(self) -> None:
        """Count every message given so far as durable: its chunk reached the file."""
        for t in self._topics.values():
            t.durable = t.count
        self.durable_count = self.message_count
        if self.message_count:
            self._durable_span = (self._mcap.first, self._mcap.last)

    def flush(self) -> None:
        """Write the chunk in progress (if any) to the OS now."""
        self._check_open()
        self._mcap.flush()

    def add_metadata(self, name: str, data: dict) -> None:
        """Add an MCAP metadata record (string -> string)."""
        self._check_open()
        self._guard(self._mcap.add_metadata, name, {str(k): str(v) for k, v in data.items()})

    def set_drive_params(self, params) -> None:
        """Store the drive parameters (a DriveParams or SI mapping) for plots and analysis."""
        values = params.as_dict() if hasattr(params, 'as_dict') else dict(params)
        text = json.dumps(values, sort_keys=True)
        self.add_metadata(DRIVE_METADATA, {'drive_params': text})
        self._custom[f'{DRIVE_METADATA}.drive_params'] = text
        self._write_metadata_yaml()

    def mark_incomplete(self, reason: str) -> None:
        """Record that the bag was cut short, and why.

        In metadata.yaml (``custom_data``, key ``abb_ros.incomplete``) and in an MCAP metadata
        record of that name.
        """
        self._custom[INCOMPLETE_KEY] = reason
        if not self.closed:
            self.add_metadata(INCOMPLETE_KEY, {'reason': reason})
            self._write_metadata_yaml()

    def topic_counts(self) -> dict[str, int]:
        """Return topic name -> messages written so far."""
        return {t.name: t.count for t in self._topics.values()}

    def set_custom_data(self, key: str, text: str) -> None:
        """Set a ``custom_data`` entry of metadata.yaml (and of the summary's rosbag2 record)."""
        self._custom[key] = text
        self._write_metadata_yaml()

    def close(self) -> None:
        """Finish the MCAP (summary, rosbag2 metadata record) and write ``metadata.yaml``."""
        if self.closed:
            return
        self._guard(self._mcap.add_metadata, 'rosbag2',    # the last chunk is written below
                    {'serialized_metadata': dump_yaml(self.metadata(durable=False))})
        self._guard(self._mcap.finish)
        self.closed = True
        self._mcap.channels.clear()   # every write now asks _checked, which raises
        self._sink.close()
        self._write_metadata_yaml()
        (self.path / _RESERVE).unlink(missing_ok=True)

    def metadata(self, durable: bool = True) -> dict:
        """Return the bag metadata (rosbag2's BagMetadata, version 9) as a dict.

        With ``durable`` it counts only the messages in chunks that reached the file.
        """
        if durable:
            count = self.durable_count
            start, end = self._durable_span or (0, 0)
        else:
            count = self.message_count
            start, end = (self._mcap.first, self._mcap.last) if count else (0, 0)
        duration = end - start if count else 0
        file_name = self.mcap_path.name
        topics = [{'topic_metadata': {'name': t.name, 'type': t.type,
                                      'serialization_format': 'cdr',
                                      'offered_qos_profiles': t.qos,
                                      'type_description_hash': t.type_hash},
                   'message_count': t.durable if durable else t.count}
                  for t in self._topics.values()]
        return {'version': METADATA_VERSION, 'storage_identifier': STORAGE_ID,
                'duration': {'nanoseconds': duration},
                'starting_time': {'nanoseconds_since_epoch': start},
                'message_count': count, 'topics_with_message_count': topics,
                'compression_format': '', 'compression_mode': '',
                'relative_file_paths': [file_name],
                'files': [{'path': file_name,
                           'starting_time': {'nanoseconds_since_epoch': start},
                           'duration': {'nanoseconds': duration},
                           'message_count': count}],
                'custom_data': dict(self._custom) or None, 'ros_distro': ROS_DISTRO}

    def _write_metadata_yaml(self) -> None:
        text = dump_yaml({'rosbag2_bagfile_information': self.metadata()}) + '\n'
        target = self.path / 'metadata.yaml'
        tmp = target.with_suffix('.yaml.tmp')
        try:
            tmp.write_text(text, encoding='utf-8')
            os.replace(tmp, target)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            if self.error is None:
                self._fail(exc)
            return
        if not self.closed and self._reserved < max(_MIN_RESERVE, 2 * len(text)):
            try:
                (self.path / _RESERVE).write_bytes(bytes(max(_MIN_RESERVE, 2 * len(text))))
                self._reserved = max(_MIN_RESERVE, 2 * len(text))
            except OSError:     # the disk is nearly full: keep the reserve there is
                pass

    def _guard(self, fn, *args, **kwargs):
        """Return what a method of the MCAP file returns; a refused write ends in :meth:`_fail`."""
        try:
            return fn(*args, **kwargs)
        except OSError as exc:
            self._fail(exc)

    def _fail(self, exc: OSError):
        """Handle a refused write: cut the half-written record, close, keep the bag readable."""
        self.error = exc
        self.closed = True
        self._mcap.channels.clear()
        self._custom[INCOMPLETE_KEY] = (f'writing stopped: {exc.strerror or exc}; '
                                        f'{self.durable_count} messages kept')
        self._sink.cut()
        try:
            self._sink.close()
        except OSError:
            pass
        (self.path / _RESERVE).unlink(missing_ok=True)   # room for the last metadata.yaml
        self._write_metadata_yaml()
        raise BagWriteError(exc.errno, f'writing {self.mcap_path} failed ({exc.strerror or exc}); '
                            f'the bag is closed, readable up to its last complete chunk')

    def _check_open(self) -> None:
        if self.closed:
            raise BagError(f'bag {self.path} is closed' + (
                f' after a write error: {self.error}' if self.error else ''))



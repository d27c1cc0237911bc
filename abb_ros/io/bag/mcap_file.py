"""An MCAP file (the public MCAP specification, version 0) written record by record.

:class:`McapFile` writes the whole file: the magic, the header, the schemas and channels, the
messages in chunks with their message indexes, the metadata records, and at the end the
summary (schemas, channels, statistics, chunk and metadata indexes, summary offsets) and the
footer. The records other than messages, chunks and message indexes are built by the public
record classes of the ``mcap`` package (``mcap.records``, ``mcap.data_stream.RecordBuilder``);
the file's layout and bookkeeping are this module's, so no writer's private state is read and
the bytes are the ones mcap's own ``Writer`` writes for the same calls (test/io/bag/test_bag.py
replays a bag through it and compares the records).

Messages cost one struct pack each: :meth:`McapFile.write` gathers the records of the open
chunk in one ``bytearray`` with their index entries in flat lists (mcap's ``Writer`` builds a
record object per message and writes it field by field, about 20 us per message). When the
chunk passes ``chunk_size`` (as mcap ends a chunk) it is compressed (zstd level 1: on the
messages of a simulation as small as level 3, mcap's, in about 2/3 of the time) and written
whole, then its message index records; schema and channel records go into the open chunk, as
mcap puts them there.
"""

from __future__ import annotations

import struct
import sys
import time
import zlib
from array import array

import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

__all__ = ['MAGIC', 'McapFile']

MAGIC = bytes((137, 77, 67, 65, 80, 48, 13, 10))
"""The first and the last eight bytes of an MCAP file."""
_CHUNK_OPCODE = 0x06
_MESSAGE_OPCODE = 0x05
_MESSAGE_INDEX_OPCODE = 0x07
_MESSAGE = struct.Struct('<BQHIQQ')   # opcode, record length, channel, sequence, log, publish
_MESSAGE_FIELDS = 2 + 4 + 8 + 8       # record length = these + the data
_pack_message = _MESSAGE.pack
_monotonic = time.monotonic
_NO_TIME = 2 ** 64                    # McapFile.first before the first message [ns]
_CHUNK_HEAD = struct.Struct('<BQQQQII')  # opcode, length, start, end, size, crc, name length
_INDEX_HEAD = struct.Struct('<BQHI')   # opcode, record length, channel, entries length
_FOOTER_HEAD = struct.Struct('<BQQQ')  # opcode, record length, summary start, offsets start
_ZSTD_LEVEL = 1                       # on bags as small as mcap's level 3, in 2/3 of the time
_ZSTD = zstandard.ZstdCompressor(level=_ZSTD_LEVEL)
COMPRESSIONS = ('zstd', 'lz4', '')
"""Chunk compressions as the MCAP specification names them ('' for none)."""


def _u64_le(values: list[int]) -> bytes:
    """Return ``values`` as little-endian unsigned 64-bit integers."""
    packed = array('Q', values)
    if sys.byteorder != 'little':
        packed.byteswap()
    return packed.tobytes()


def _compress(name: str, data) -> bytes:
    """Return ``data`` compressed as an MCAP chunk's ``compression`` ``name`` says."""
    if name == 'zstd':
        return _ZSTD.compress(data)
    if name == 'lz4':
        import lz4.frame
        return lz4.frame.compress(data)
    return bytes(data)


def _record(*records) -> bytes:
    """Return the bytes of mcap ``records`` (``mcap.records`` objects), one after another."""
    builder = RecordBuilder()
    for record in records:
        record.write(builder)
    return builder.end()


class McapFile:
    """Write an MCAP file: chunked, zstd or lz4 or none, with CRCs, indexes and a summary.

    ``start`` writes the header; ``register_schema``, ``register_channel``, ``add_metadata``
    and ``write`` (the next message of a topic, sequence numbers counted per topic) follow in
    any order; ``finish`` ends the file. A chunk in progress is written at least every
    ``flush_period`` seconds.

    Parameters
    ----------
    stream : file-like
        ``write`` (every call reaches the file whole), ``tell`` and ``flush``.
    chunk_size : int
        A chunk ends with the message that takes its records past this size [bytes].
    compression : str
        ``'zstd'``, ``'lz4'`` or ``''`` (none).
    flush_period : float
        The longest time a chunk stays open [s].
    resolve : callable(topic, message) -> (entry, bytes)
        Called for a topic that is not in :attr:`channels` or a message that is not
        ``bytes``: returns the topic's entry and the message's bytes, or raises.
    on_error : callable(OSError)
        Called with a write that the file refused; raises.

    Attributes
    ----------
    channels : dict
        Topic (as ``write`` is given it) -> entry with ``channel_id`` and ``count``, the
        messages written so far (the next sequence number).
    first, last : int
        The earliest and the latest log time written so far [ns] (``first`` huge before one).
    """

    def __init__(self, stream, chunk_size: int, compression: str = 'zstd',
                 flush_period: float = 1.0, resolve=None, on_error=None):
        if compression not in COMPRESSIONS:
            raise ValueError(f'compression must be one of {COMPRESSIONS}, got {compression!r}')
        self._stream = stream
        self._chunk_size = int(chunk_size)
        self._compression = compression
        self.channels: dict = {}
        self.first = _NO_TIME
        self.last = 0
        self._flush_period = float(flush_period)
        self._next_flush = _monotonic() + self._flush_period
        self._resolve = resolve
        self._on_error = on_error
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._stats = Statistics(attachment_count=0, channel_count=0, channel_message_counts={},
                                 chunk_count=0, message_count=0, metadata_count=0,
                                 message_start_time=0, message_end_time=0, schema_count=0)
        self._batch = bytearray()     # the records of the open chunk
        self._index: dict[int, list[int]] = {}   # channel -> [log time, offset, ...]

    def start(self, profile: str, library: str) -> None:
        """Write the magic and the header record."""
        self._stream.write(MAGIC)
        self._stream.write(_record(Header(profile=profile, library=library)))

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Add a schema record to the open chunk and the summary.

        Returns
        -------
        int
            The schema's id (1, 2, ...).
        """
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(schema)
        self._stats.schema_count += 1
        self._batch += _record(schema)
        return schema.id

    def register_channel(self, topic: str, message_encoding: str, schema_id: int,
                         metadata: dict[str, str]) -> int:
        """Add a channel record to the open chunk and the summary.

        Returns
        -------
        int
            The channel's id (1, 2, ...).
        """
        channel = Channel(id=len(self._channels) + 1, topic=topic,
                          message_encoding=message_encoding, schema_id=schema_id,
                          metadata=metadata)
        self._channels.append(channel)
        self._stats.channel_count += 1
        self._batch += _record(channel)
        return channel.id

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Write a metadata record into the data section now (between chunks)."""
        offset = self._stream.tell()
        self._stats.metadata_count += 1
        record = _record(Metadata(name=name, metadata=data))
        self._metadata_indexes.append(MetadataIndex(offset=offset, length=len(record),
                                                    name=name))
        self._stream.write(record)

    def write(self, topic: str, message, log_time: int, publish_time: int | None = None
              ) -> None:
        """Append one message of ``topic`` (a key of :attr:`channels`), as mcap writes it."""
        entry = self.channels.get(topic)
        if entry is None or type(message) is not bytes:
            entry, message = self._resolve(topic, message)
        log_time = int(log_time)
        # counted first: the chunk that holds this message may be written within this call
        sequence = entry.count
        entry.count += 1
        if log_time < self.first:
            self.first = log_time
        if log_time > self.last:
            self.last = log_time
        channel_id = entry.channel_id
        batch = self._batch
        index = self._index.get(channel_id)
        if index is None:
            index = self._index[channel_id] = []
        index += (log_time, len(batch))
        batch += _pack_message(_MESSAGE_OPCODE, _MESSAGE_FIELDS + len(message), channel_id,
                               sequence, log_time,
                               log_time if publish_time is None else int(publish_time))
        batch += message
        if len(batch) > self._chunk_size:
            self._end_chunk()
        if _monotonic() >= self._next_flush:
            self.flush()

    def write_many(self, messages, log_time: int) -> None:
        """Append ``messages``, (topic, bytes) pairs, all at ``log_time``, as :meth:`write`."""
        log_time = int(log_time)
        if log_time < self.first:
            self.first = log_time
        if log_time > self.last:
            self.last = log_time
        channels, indexes, batch = self.channels, self._index, self._batch
        chunk_size, pack = self._chunk_size, _pack_message
        for topic, message in messages:
            entry = channels.get(topic)
            if entry is None or type(message) is not bytes:
                entry, message = self._resolve(topic, message)
            sequence = entry.count
            entry.count += 1
            channel_id = entry.channel_id
            index = indexes.get(channel_id)
            if index is None:
                index = indexes[channel_id] = []
            index += (log_time, len(batch))
            batch += pack(_MESSAGE_OPCODE, _MESSAGE_FIELDS + len(message), channel_id,
                          sequence, log_time, log_time)
            batch += message
            if len(batch) > chunk_size:
                self._end_chunk()
                indexes, batch = self._index, self._batch
        if _monotonic() >= self._next_flush:
            self.flush()

    def _end_chunk(self) -> None:
        """Write the open chunk, which is full."""
        try:
            self.close_chunk()
        except OSError as exc:
            self._on_error(exc)

    def flush(self) -> None:
        """Write the open chunk now; the next flush is due ``flush_period`` later."""
        try:
            self.close_chunk()
            self._stream.flush()
        except OSError as exc:
            self._on_error(exc)
        self._next_flush = _monotonic() + self._flush_period

    def close_chunk(self) -> None:
        """Write the open chunk (if it holds a message) and its message index to ``stream``."""
        if not self._index:
            return
        chunk, index, name = self._batch, self._index, self._compression.encode()
        self._batch, self._index = bytearray(), {}
        size, crc, data = len(chunk), zlib.crc32(chunk), _compress(self._compression, chunk)
        start = min(min(flat[0::2]) for flat in index.values())
        end = max(max(flat[0::2]) for flat in index.values())
        stats = self._stats
        if stats.message_count == 0 or start < stats.message_start_time:
            stats.message_start_time = start
        stats.message_end_time = max(stats.message_end_time, end)
        for channel_id, flat in index.items():
            counts = stats.channel_message_counts
            counts[channel_id] = counts.get(channel_id, 0) + len(flat) // 2
            stats.message_count += len(flat) // 2
        stats.chunk_count += 1
        length = 8 + 8 + 8 + 4 + 4 + len(name) + 8 + len(data)
        chunk_start = self._stream.tell()
        self._stream.write(_CHUNK_HEAD.pack(_CHUNK_OPCODE, length, start, end, size, crc,
                                            len(name))
                           + name + struct.pack('<Q', len(data)) + data)
        index_start = self._stream.tell()
        records, offsets = [], {}
        for channel_id, flat in index.items():
            offsets[channel_id] = index_start + sum(len(r) for r in records)
            records.append(_INDEX_HEAD.pack(_MESSAGE_INDEX_OPCODE, 2 + 4 + 8 * len(flat),
                                            channel_id, 8 * len(flat))
                           + _u64_le(flat))
        self._stream.write(b''.join(records))
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=start, message_end_time=end, chunk_start_offset=chunk_start,
            chunk_length=1 + 8 + length, message_index_offsets=offsets,
            message_index_length=self._stream.tell() - index_start,
            compression=name.decode(), compressed_size=len(data), uncompressed_size=size))

    def finish(self) -> None:
        """Write the open chunk, the data end, the summary, the footer and the closing magic.

        The summary as mcap's ``Writer`` lays it out: the schemas, the channels, the
        statistics, the chunk indexes, the (empty) attachment indexes and the metadata indexes,
        each group with its summary offset record; the footer's CRC covers the summary and the
        footer's fields before it.
        """
        self.close_chunk()
        self._stream.write(_record(DataEnd(data_section_crc=0)))
        summary_start = self._stream.tell()
        groups = ((Opcode.SCHEMA, self._schemas), (Opcode.CHANNEL, self._channels),
                  (Opcode.STATISTICS, [self._stats]),
                  (Opcode.CHUNK_INDEX, self._chunk_indexes), (Opcode.ATTACHMENT_INDEX, []),
                  (Opcode.METADATA_INDEX, self._metadata_indexes))
        summary, offsets = bytearray(), []
        for opcode, records in groups:
            group = _record(*records)
            offsets.append(SummaryOffset(group_opcode=opcode,
                                         group_start=summary_start + len(summary),
                                         group_length=len(group)))
            summary += group
        offsets_start = summary_start + len(summary)
        summary += _record(*offsets)
        crc = zlib.crc32(_FOOTER_HEAD.pack(Opcode.FOOTER, 8 + 8 + 4, summary_start,
                                           offsets_start), zlib.crc32(summary))
        self._stream.write(bytes(summary))
        self._stream.write(_record(Footer(summary_start=summary_start,
                                          summary_offset_start=offsets_start,
                                          summary_crc=crc)))
        self._stream.write(MAGIC)

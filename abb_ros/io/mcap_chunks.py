"""The chunks of an ``mcap.writer.Writer``'s data section, written at a fraction of its cost.

``Writer.add_message`` builds a ``Message`` record object and writes it field by field through
``RecordBuilder`` (six struct packs, a seek back for the length), and at the end of a chunk
writes each message index entry with two more calls: about 20 us per message in Python.
:class:`ChunkWriter` takes the messages of a bag (topic lookup, sequence numbers, time range)
and gathers the records of the open chunk in one ``bytearray`` (one struct pack per message)
with their index entries in flat lists. When the chunk is full it compresses it (zstd level 1:
on the messages of a simulation as small as level 3, mcap's, in about 2/3 of the time), writes
the Chunk record whole, then its message index records (one pack each), and adds the chunk to
the writer's statistics and chunk index for the summary.

A chunk ends as ``add_message`` ends it (when its records pass ``chunk_size``), so the records
are those mcap writes; only the compressed bytes differ (the level). Schema and channel records
that the writer puts in its own chunk are moved into the open one (:meth:`ChunkWriter.absorb`).
The writer's state is private, so the class checks at construction that the writer is the one
it was written for (mcap 1.6, chunked, with CRCs): otherwise every message goes through
``add_message`` (``fast`` says which). test/test_bag.py checks that both ways hold the same
records.
"""

from __future__ import annotations

import struct
import sys
import time
import zlib
from array import array
from io import BytesIO

import zstandard
from mcap.records import ChunkIndex
from mcap.writer import CompressionType, Writer

__all__ = ['ChunkWriter']

_CHUNK_OPCODE = 0x06
_MESSAGE_OPCODE = 0x05
_MESSAGE_INDEX_OPCODE = 0x07
_MESSAGE = struct.Struct('<BQHIQQ')   # opcode, record length, channel, sequence, log, publish
_MESSAGE_FIELDS = 2 + 4 + 8 + 8       # record length = these + the data
_pack_message = _MESSAGE.pack
_monotonic = time.monotonic
_NO_TIME = 2 ** 64                    # ChunkWriter.first before the first message [ns]
_CHUNK_HEAD = struct.Struct('<BQQQQII')  # opcode, length, start, end, size, crc, name length
_INDEX_HEAD = struct.Struct('<BQHI')   # opcode, record length, channel, entries length
_ZSTD_LEVEL = 1                       # on bags as small as mcap's level 3, in 2/3 of the time
_ZSTD = zstandard.ZstdCompressor(level=_ZSTD_LEVEL)
_NAMES = {CompressionType.ZSTD: 'zstd', CompressionType.LZ4: 'lz4', CompressionType.NONE: ''}


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


class ChunkWriter:
    """Write messages into the chunks of an MCAP writer's data section.

    ``write(topic, data, log_time)`` is ``writer.add_message`` with the next sequence number
    of the topic; a chunk in progress is written at least every ``flush_period`` seconds.

    Parameters
    ----------
    writer : mcap.writer.Writer
        A chunked writer with CRCs and message indexes, started, whose output is ``stream``.
    stream : file-like
        ``write`` (every call reaches the file whole) and ``tell``.
    compression : mcap.writer.CompressionType
        As the writer was given it.
    fast : bool
        Write the chunks here (the default); with False every message is ``add_message``.
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

    def __init__(self, writer: Writer, stream, compression: CompressionType,
                 fast: bool = True, flush_period: float = 1.0, resolve=None, on_error=None):
        self._writer = writer
        self._stream = stream
        self.channels: dict = {}
        self.first = _NO_TIME
        self.last = 0
        self._flush_period = float(flush_period)
        self._next_flush = _monotonic() + self._flush_period
        self._resolve = resolve
        self._on_error = on_error
        self.fast = False
        try:
            self._stats = writer._Writer__statistics
            self._builder = writer._Writer__chunk_builder
            self._chunk_size = writer._Writer__chunk_size
            self._chunk_indexes = writer._Writer__chunk_indices
            self.fast = fast and (
                self._builder is not None and writer._Writer__enable_crcs
                and isinstance(getattr(self._builder.record_writer, '_buffer', None), BytesIO))
        except AttributeError:
            pass
        self._compression = _NAMES[compression]
        self._batch = bytearray()     # the records of the open chunk
        self._index: dict[int, list[int]] = {}   # channel -> [log time, offset, ...]
        if not self.fast:   # every message through add_message
            self.write, self.write_many = self._write_slow, self._write_many_slow

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

    def _write_slow(self, topic: str, message, log_time: int, publish_time: int | None = None
                    ) -> None:
        entry, message, log_time = self._count(topic, message, log_time)
        try:
            self._writer.add_message(
                channel_id=entry.channel_id, log_time=log_time, data=message,
                publish_time=log_time if publish_time is None else int(publish_time),
                sequence=entry.count - 1)
        except OSError as exc:
            self._on_error(exc)
        if _monotonic() >= self._next_flush:
            self.flush()

    def _write_many_slow(self, messages, log_time: int) -> None:
        for topic, message in messages:
            self._write_slow(topic, message, log_time)

    def _count(self, topic: str, message, log_time: int):
        entry = self.channels.get(topic)
        if entry is None or type(message) is not bytes:
            entry, message = self._resolve(topic, message)
        log_time = int(log_time)
        entry.count += 1
        self.first, self.last = min(self.first, log_time), max(self.last, log_time)
        return entry, message, log_time

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
            self._writer.flush()
        except OSError as exc:
            self._on_error(exc)
        self._next_flush = _monotonic() + self._flush_period

    def absorb(self) -> None:
        """Move the records the writer put in its own chunk (schemas, channels) to the open one.

        Call after each writer call that may add them.
        """
        if self.fast and self._builder.count:
            self._batch += self._builder.end()

    def close_chunk(self) -> None:
        """Write the open chunk (if it holds a message) and its message index to ``stream``."""
        if not self.fast or not self._index:
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
            stats.channel_message_counts[channel_id] += len(flat) // 2
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

"""Appending messages to an ``mcap.writer.Writer`` at a fraction of ``add_message``'s cost.

``Writer.add_message`` builds a ``Message`` record object and writes it field by field through
``RecordBuilder`` (six struct packs, a seek back for the length): about 20 us per message in
Python, most of a recorder's time at 5 kHz. :class:`MessageAppender` does the same
bookkeeping (the file's statistics, the chunk's time range and message index, the chunk
finished when full) and writes the record with one struct pack. It works on the writer's
private state, so it checks at construction that the writer is the one it was written for
(mcap 1.6, chunked): otherwise it calls ``add_message`` (``fast`` says which).
test/test_bag.py checks that both ways give the same file, byte for byte.
"""

from __future__ import annotations

import struct
from io import BytesIO

from mcap.records import MessageIndex
from mcap.writer import Writer

__all__ = ['MessageAppender']

_MESSAGE_OPCODE = 0x05
_MESSAGE = struct.Struct('<BQHIQQ')   # opcode, record length, channel, sequence, log, publish
_MESSAGE_FIELDS = 2 + 4 + 8 + 8       # record length = these + the data


class MessageAppender:
    """``add(channel_id, log_time, data, publish_time, sequence)`` = ``writer.add_message``."""

    def __init__(self, writer: Writer, fast: bool = True):
        self._writer = writer
        self.fast = False
        if not fast:
            return
        try:
            self._stats = writer._Writer__statistics
            self._chunk = writer._Writer__chunk_builder
            self._chunk_size = writer._Writer__chunk_size
            self._finalize = writer._Writer__maybe_finalize_chunk
        except AttributeError:
            return
        self.fast = (self._chunk is not None
                     and isinstance(getattr(self._chunk.record_writer, '_buffer', None), BytesIO)
                     and hasattr(self._chunk, 'message_indices'))

    def add(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
            sequence: int) -> None:
        """Append one message record, as ``writer.add_message`` would."""
        if not self.fast:
            self._writer.add_message(channel_id=channel_id, log_time=log_time, data=data,
                                     publish_time=publish_time, sequence=sequence)
            return
        stats = self._stats
        _widen(stats, log_time, stats.message_count == 0)
        stats.channel_message_counts[channel_id] += 1
        stats.message_count += 1
        chunk = self._chunk
        _widen(chunk, log_time, chunk.num_messages == 0)
        buffer = chunk.record_writer._buffer     # a new BytesIO after every chunk
        index = chunk.message_indices.get(channel_id)
        if index is None:
            index = chunk.message_indices[channel_id] = MessageIndex(channel_id=channel_id,
                                                                     records=[])
        index.records.append((log_time, buffer.tell()))
        chunk.num_messages += 1
        buffer.write(_MESSAGE.pack(_MESSAGE_OPCODE, _MESSAGE_FIELDS + len(data), channel_id,
                                   sequence, log_time, publish_time))
        buffer.write(data)
        if buffer.tell() > self._chunk_size:
            self._finalize()


def _widen(record, log_time: int, empty: bool) -> None:
    """Extend the message time range of ``record`` (statistics or chunk) to ``log_time``."""
    if empty or log_time < record.message_start_time:
        record.message_start_time = log_time
    if log_time > record.message_end_time:
        record.message_end_time = log_time

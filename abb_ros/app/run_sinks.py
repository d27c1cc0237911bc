"""Where a headless run's messages go: a bag, a live view, or both, optionally at real time.

:func:`abb_ros.app.headless.run_scenario` hands its messages to one ``bag`` (``add_topic``,
``write_many``); :class:`Sinks` is that one object for several, so the bag and the live view
get the same CDR bytes with the same stamps. With ``real_time`` a message is held until the
wall clock has caught up with its stamp (counted from the first message), so a viewer sees the
run unfold at 1 simulated second per wall second; a run that cannot keep up goes as fast as it
can.
"""

from __future__ import annotations

import time

from abb_ros.io.sink import BatchSink

__all__ = ['AHEAD_S', 'Sinks']

AHEAD_S = 0.002
"""How far a message may run ahead of the wall clock before the run sleeps [s]."""


class Sinks:
    """Several message sinks as one, paced at real time or not.

    Parameters
    ----------
    sinks : list of abb_ros.io.sink.MessageSink
        :class:`abb_ros.io.bag.writer.BagWriter`, :class:`abb_ros.io.live_view.server.LiveView`
        (a :class:`~abb_ros.io.sink.BatchSink` itself).
    real_time : bool
        Whether to hold each message until the wall clock reaches its stamp.
    clock : callable
        The wall clock [s] (``time.perf_counter``); ``sleep`` waits [s].
    """

    def __init__(self, sinks, real_time: bool = False, clock=time.perf_counter,
                 sleep=time.sleep):
        self.sinks = list(sinks)
        self.real_time = real_time
        self._clock = clock
        self._sleep = sleep
        self._origin = None   # (first stamp [ns], wall clock then [s])
        self._many = [_write_many_of(sink) for sink in self.sinks]
        if len(self._many) == 1 and not real_time:   # one sink, unpaced: straight to it
            self.write_many = self._many[0]

    def add_topic(self, topic: str, type_name: str) -> None:
        """Add ``topic`` to every sink."""
        for sink in self.sinks:
            sink.add_topic(topic, type_name)

    def write(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Write one message to every sink (at real time: not before its stamp is due)."""
        if self.real_time:
            self._wait_for(stamp_ns)
        for sink in self.sinks:
            sink.write(topic, data, stamp_ns)

    def write_many(self, messages, stamp_ns: int) -> None:
        """Write several messages of one stamp, (topic, CDR bytes) pairs, to every sink.

        The same as :meth:`write` for each in turn.
        """
        if self.real_time:
            self._wait_for(stamp_ns)
        for write_many in self._many:
            write_many(messages, stamp_ns)

    def _wait_for(self, stamp_ns: int) -> None:
        if self._origin is None:
            self._origin = (stamp_ns, self._clock())
        first, start = self._origin
        ahead = (stamp_ns - first) * 1e-9 - (self._clock() - start)
        if ahead > AHEAD_S:
            self._sleep(ahead)


def _write_many_of(sink):
    """Return ``sink.write_many`` (a BatchSink), or a loop over ``sink.write``."""
    if isinstance(sink, BatchSink):
        return sink.write_many

    def write_each(messages, stamp_ns: int) -> None:
        for topic, data in messages:
            sink.write(topic, data, stamp_ns)
    return write_each

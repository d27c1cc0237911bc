"""The contract of a message sink: where stamped CDR messages go.

A bag (:class:`abb_ros.io.bag.writer.BagWriter`), a live view
(:class:`abb_ros.io.live_view.server.LiveView`) and several of them at once
(:class:`abb_ros.app.run_sinks.Sinks`) take the same calls, so a headless run and the
simulator hand them the same bytes with the same stamps. ``write_many`` is a sample's messages
in one call (what a bag writes fastest); a sink without it gets ``write`` for each.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Protocol, runtime_checkable

__all__ = ['MessageSink', 'BatchSink']


@runtime_checkable
class MessageSink(Protocol):
    """Takes a topic's type once, then its messages (CDR bytes) with their stamps [ns]."""

    def add_topic(self, topic: str, type_name: str) -> None:
        """Make ``topic`` of ROS type ``type_name`` (``pkg/msg/Name``) known."""

    def write(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Take one message of ``topic`` stamped ``stamp_ns``."""


@runtime_checkable
class BatchSink(MessageSink, Protocol):
    """A :class:`MessageSink` that takes several messages of one stamp in one call."""

    def write_many(self, messages: Iterable[tuple[str, bytes]], stamp_ns: int) -> None:
        """Take (topic, CDR bytes) pairs stamped ``stamp_ns``: ``write`` for each in turn."""

"""The recorder node's parameters.

The default ``topics`` are the recorded topics of the topic list
(:func:`abb_ros.io.wire.topics.recorded_topics`), the default chunk size the bag writer's.
"""

from __future__ import annotations

from abb_ros.io.bag.writer import DEFAULT_CHUNK_SIZE
from abb_ros.io.wire.topics import recorded_topics
from abb_ros.model.parameters.param_spec import INTEGER, STRING, STRING_ARRAY, ParamSpec

__all__ = ['RECORDER_SPECS']


RECORDER_SPECS = (
    ParamSpec('topics', [t.name for t in recorded_topics()], '',
              'topics to record (relative names resolve in the node\'s namespace)',
              STRING_ARRAY, applies='at start-up'),
    ParamSpec('output', '', '', 'bag directory (must not exist); empty: '
              'abb_bag_<date>-<time>', STRING, applies='at start-up'),
    ParamSpec('chunk_size', DEFAULT_CHUNK_SIZE, 'bytes', 'MCAP chunk size; a crash loses at '
              'most one chunk', INTEGER, 256, 1 << 30, applies='at start-up'),
    ParamSpec('compression', 'zstd', '', 'chunk compression', STRING,
              choices=('zstd', 'lz4', 'none'), applies='at start-up'),
    ParamSpec('queue_depth', 1000, 'messages', 'subscription queue depth (1 s at 1 kHz)',
              INTEGER, 1, 100000, applies='at start-up'),
    ParamSpec('discovery_period', 0.5, 's', 'how often the graph is searched for new topics; '
              '10 ms (a search costs about a millisecond) to an hour (a timer period rcl '
              'holds in int64 nanoseconds)', low=0.01, high=3600.0, applies='at start-up'),
)
"""The recorder node's parameters."""

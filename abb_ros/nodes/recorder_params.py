"""The recorder node's parameters.

The default ``topics`` are the recorded topics of the topic list
(:func:`abb_ros.io.topics.recorded_topics`), the default chunk size the bag writer's.
"""

from __future__ import annotations

import math

from abb_ros.io.bag_writer import DEFAULT_CHUNK_SIZE
from abb_ros.io.topics import recorded_topics
from abb_ros.model.parameters.param_spec import INTEGER, STRING, STRING_ARRAY, ParamSpec

__all__ = ['RECORDER_SPECS']

_REC = ('recorder',)

RECORDER_SPECS = (
    ParamSpec('topics', [t.name for t in recorded_topics()], '',
              'topics to record (relative names resolve in the node\'s namespace)',
              STRING_ARRAY, applies='at start-up', nodes=_REC),
    ParamSpec('output', '', '', 'bag directory (must not exist); empty: '
              'abb_bag_<date>-<time>', STRING, applies='at start-up', nodes=_REC),
    ParamSpec('chunk_size', DEFAULT_CHUNK_SIZE, 'bytes', 'MCAP chunk size; a crash loses at '
              'most one chunk', INTEGER, 256, 1 << 30, applies='at start-up', nodes=_REC),
    ParamSpec('compression', 'zstd', '', 'chunk compression', STRING,
              choices=('zstd', 'lz4', 'none'), applies='at start-up', nodes=_REC),
    ParamSpec('queue_depth', 1000, 'messages', 'subscription queue depth (1 s at 1 kHz)',
              INTEGER, 1, 100000, applies='at start-up', nodes=_REC),
    ParamSpec('discovery_period', 0.5, 's', 'how often the graph is searched for new topics',
              low=0.0, low_open=True, high=math.inf, applies='at start-up', nodes=_REC),
)
"""The recorder node's parameters."""

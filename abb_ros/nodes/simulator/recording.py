"""The recordings a node starts and stops itself: the simulator's ``record.*``.

:class:`InProcessRecording` holds at most one :class:`abb_ros.nodes.recorder.recording.Recording`
at a time, of the node's own messages (queued by :meth:`Recording.write` as they are published,
written by a drain timer) and of the topics of the graph it is given; it offers
``~/start_recording`` and ``~/stop_recording`` and ends a recording that the disk refused.
"""

from __future__ import annotations

from rclpy.node import Node
from std_srvs.srv import Trigger

from abb_ros.io.bag.writer import BagError, BagWriter
from abb_ros.model.parameters.param_spec import ParamError
from abb_ros.nodes.recorder.recording import (
    DRAIN_PERIOD_S,
    Recording,
    default_output,
    resolve_topics,
)

__all__ = ['InProcessRecording']


class InProcessRecording:
    """The recordings a node starts and stops itself, of its own messages.

    At most one at a time (:attr:`current`). A drain timer, made at the first start, writes
    the node's queued messages (:meth:`Recording.write`) and those of the topics of the graph;
    with topics of the graph, a discovery timer too. Both serve every later recording.

    Parameters
    ----------
    node : Node
        The node recording.
    depth : int
        Queue depth of each subscription to a topic of the graph.
    param : str
        The parameter that names those topics (for errors).
    discovery_s : float
        How often the graph is searched for them [s].
    drain_s : float
        How often the queued messages are written to the bag [s]: ``depth`` messages of a
        topic of the graph must last this long at its rate (the log times are the receive
        times and the stamps, whenever they are written).
    """

    def __init__(self, node: Node, depth: int, param: str, discovery_s: float,
                 drain_s: float = DRAIN_PERIOD_S):
        self.node = node
        self.current: Recording | None = None
        self.error = ''      # why the last recording stopped ('' it did not fail)
        self._depth = depth
        self._param = param
        self._discovery_s = discovery_s
        self._drain_s = drain_s
        self._discovery = self._drain_timer = None

    def serve(self, path_param: str, prepare=None) -> None:
        """Offer ``~/start_recording`` and ``~/stop_recording`` (std_srvs/Trigger).

        A start records to the parameter ``path_param`` (a directory), or to
        :func:`default_output` when it is empty, with the topics of the parameter this
        object was made for.
        """
        def start(_request, response):
            path = self.node.get_parameter(path_param).value or default_output()
            error = self.start(path, self.node.get_parameter(self._param).value, prepare)
            response.success = not error
            response.message = error or f'recording to {self.current.bag.path}'
            return response

        def stop(_request, response):
            response.success = self.current is not None
            response.message = self.stop()
            return response

        self.node.create_service(Trigger, '~/start_recording', start)
        self.node.create_service(Trigger, '~/stop_recording', stop)

    def start(self, path: str, topics=(), prepare=None) -> str:
        """Record the node's messages from now on, and ``topics``, to a new bag at ``path``.

        ``prepare(bag)`` runs on the new bag first. Returns '' or why not.
        """
        if self.current is not None:
            return f'already recording to {self.current.bag.path}'
        try:   # before the bag: a bad name leaves no directory behind
            resolve_topics(self.node, topics, self._param)
        except ParamError as err:
            return str(err)
        try:
            bag = BagWriter(path)
            if prepare is not None:
                prepare(bag)
        except (BagError, OSError) as exc:
            return str(exc)
        self.error = ''
        self.current = Recording(self.node, bag, list(topics) or None, self._depth,
                                 own_only=True, param=self._param, on_failure=self._failed)
        if topics:
            self.current.discover()
            if self.current is None:
                return self.error
            if self._discovery is None:
                self._discovery = self.node.create_timer(self._discovery_s, self._discover)
        if self._drain_timer is None:   # the node's own messages are queued too
            self._drain_timer = self.node.create_timer(self._drain_s, self._drain)
        self.node.get_logger().info(f'recording what this node publishes to {bag.path}'
                                    + (f' with {", ".join(topics)}' if topics else ''))
        return ''

    def _discover(self) -> None:
        if self.current is not None:
            self.current.discover()

    def _drain(self) -> None:
        if self.current is not None:
            self.current.drain()

    def stop(self) -> str:
        """Finish the bag (summary, metadata.yaml); returns a one-line account."""
        recording, self.current = self.current, None
        if recording is None:
            return 'not recording'
        error = recording.finish()
        if error:
            self.error = error
        bag = recording.bag
        text = f'{bag.message_count} messages on {len(bag.topics)} topics in {bag.path}'
        if self.error:
            text += f' ({self.error})'
        return text

    def _failed(self, reason: str) -> None:
        """Stop the recording after a write failure (logged already); the node runs on."""
        self.error = reason
        self.stop()

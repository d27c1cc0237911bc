"""Every message sink keeps the one contract (abb_ros.io.sink): same calls, same arguments."""

import inspect

import pytest

from abb_ros.app.run_sinks import Sinks
from abb_ros.io.bag.writer import BagWriter
from abb_ros.io.live_view.server import LiveView
from abb_ros.io.sink import BatchSink, MessageSink

SINKS = [BagWriter, LiveView, Sinks]


def _positional(func):
    return [p for p in inspect.signature(func).parameters.values()
            if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) and p.name != 'self']


@pytest.mark.parametrize('cls', SINKS, ids=lambda c: c.__name__)
def test_a_bag_a_live_view_and_several_sinks_are_batch_sinks(cls):
    assert issubclass(cls, BatchSink)


@pytest.mark.parametrize('cls', SINKS, ids=lambda c: c.__name__)
@pytest.mark.parametrize('method', ['add_topic', 'write', 'write_many'])
def test_each_sink_method_takes_the_protocols_arguments_in_its_order(cls, method):
    assert issubclass(cls, MessageSink)
    wanted = _positional(getattr(BatchSink, method))
    got = _positional(getattr(cls, method))
    assert len(got) >= len(wanted), (cls.__name__, method)
    extra = got[len(wanted):]
    assert all(p.default is not p.empty for p in extra), (cls.__name__, method, extra)

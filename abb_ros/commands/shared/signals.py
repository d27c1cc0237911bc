"""SIGINT/SIGTERM in `abb-sim`: raised where work can stop, deferred where it must not."""

from __future__ import annotations

import contextlib
import os
import signal

from abb_ros.commands.shared.errors import Terminated

_DEFERRED = {'depth': 0, 'pending': None}


_CALLBACK_FILES = ('weakref.py', '_weakrefset.py')


def _gc_callback_codes() -> set:
    """Return the code objects of the ``gc.callbacks`` functions (distributed has one)."""
    import gc
    return {getattr(getattr(cb, '__func__', cb), '__code__', None) for cb in gc.callbacks}


def _in_finalizer(frame) -> bool:
    """Whether ``frame`` is a finalizer, or called from one.

    A weakref callback, a ``__del__`` or a function of ``gc.callbacks``. An exception raised
    there is printed as "Exception ignored in ..." with a traceback and then dropped: the
    signal would be lost.
    """
    gc_codes = _gc_callback_codes()
    for _ in range(3):
        if frame is None:
            return False
        code = frame.f_code
        if code.co_name == '__del__' or code.co_filename.endswith(_CALLBACK_FILES) \
                or code in gc_codes:
            return True
        frame = frame.f_back
    return False


def _on_signal(signum, frame):
    if _DEFERRED['depth']:
        _DEFERRED['pending'] = signum
        return
    if _in_finalizer(frame):   # the same signal again in a moment, outside the finalizer
        import threading
        threading.Timer(0.01, os.kill, (os.getpid(), signum)).start()
        return
    raise KeyboardInterrupt if signum == signal.SIGINT else Terminated(signum)


@contextlib.contextmanager
def stop_signals():
    """Turn SIGINT into KeyboardInterrupt and SIGTERM into :class:`Terminated` while inside.

    The previous handlers come back on exit (``abb_ros.cli.main`` runs in-process in tests).
    """
    previous = {s: signal.signal(s, _on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


@contextlib.contextmanager
def signals_deferred():
    """Hold SIGINT and SIGTERM until the block is done (finishing a file must not be cut)."""
    _DEFERRED['depth'] += 1
    try:
        yield
    finally:
        _DEFERRED['depth'] -= 1
        pending, _DEFERRED['pending'] = _DEFERRED['pending'], None
        if pending is not None and not _DEFERRED['depth']:
            _on_signal(pending, None)


def stop_point(progress=None):
    """Return a progress callback that first raises a signal held by :func:`signals_deferred`.

    Work run with signals held and this callback stops between two of its chunks only, never
    in the middle of writing a message.
    """
    def report(done):
        pending, _DEFERRED['pending'] = _DEFERRED['pending'], None
        if pending is not None:
            raise KeyboardInterrupt if pending == signal.SIGINT else Terminated(pending)
        if progress is not None:
            progress(done)
    return report

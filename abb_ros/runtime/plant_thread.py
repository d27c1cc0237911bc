"""The plant's own thread: ticks paced against absolute deadlines, one lock with the executor.

At 1 kHz an rclpy timer costs more than the plant (about 80 us of executor work per tick
against 25 us of integration, docs/performance.md). :class:`PlantThread` calls the node's
``tick`` on a thread of its own instead, sleeping between ticks until the absolute deadline
the tick returns (so the wake-up error of one tick is not carried into the next), and leaves
the executor to services, parameters and subscriptions.

Everything the plant owns (the simulation, the sampler, the pacer, the bag being recorded)
is touched only under :attr:`PlantThread.lock`: the tick holds it, and the node wraps every
callback the executor runs in it (:func:`locked`). ``tick`` returns

- an absolute deadline in ``time.monotonic_ns`` nanoseconds: sleep until then;
- :data:`AGAIN`: tick again at once (as fast as possible), after letting waiting callbacks in;
- :data:`IDLE`: nothing to do (paused, fault) until :meth:`PlantThread.wake`.

:meth:`PlantThread.wake` (after a pause, a rate change, a reset ...) makes the thread tick now.
No rclpy here: the thread is tested with a plain tick (test/runtime/test_plant_thread.py).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import threading
import time
from typing import Callable

__all__ = ['AGAIN', 'IDLE', 'PlantThread', 'locked', 'name_os_thread']

AGAIN = -1
"""``tick``'s answer: tick again at once."""
IDLE = None
"""``tick``'s answer: sleep until woken."""
YIELD_S = 0.0
"""Between two as-fast-as-possible ticks the thread sleeps this long with the lock released,
so that a callback waiting for it gets it (a 0 s sleep releases the GIL)."""


PR_SET_NAME = 15
"""prctl(2) option that names the calling thread (Linux; 15 bytes at most)."""


def name_os_thread(name: str) -> bool:
    """Give the calling thread ``name`` in the kernel (``top -H``, ``ps -L``, /proc/.../comm).

    Python names its threads only for itself; returns whether the kernel took the name.
    """
    try:
        libc = ctypes.CDLL(ctypes.util.find_library('c'), use_errno=True)
        return libc.prctl(PR_SET_NAME, name.encode()[:15], 0, 0, 0) == 0
    except (OSError, AttributeError):   # no libc prctl (not Linux)
        return False


def locked(lock, callback: Callable) -> Callable:
    """Return ``callback`` run under ``lock`` (for the executor's callbacks of the node)."""
    @functools.wraps(callback)
    def run_locked(*args, **kwargs):
        with lock:
            return callback(*args, **kwargs)
    return run_locked


class PlantThread:
    """A daemon thread calling ``tick()`` under :attr:`lock` at the times it asks for.

    Parameters
    ----------
    tick : callable
        Called under the lock; returns a deadline [ns, ``time.monotonic_ns``], AGAIN or IDLE.
    lock : threading.RLock
        Shared with every callback that touches what the tick touches.
    on_error : callable
        Called (under the lock) with an exception the tick raised; the thread then idles until
        woken, so that a bug stops the plant loudly instead of ending the thread in silence.
    name : str
        The thread's name (``ps -L``, ``top -H``).
    """

    def __init__(self, tick: Callable, lock, on_error: Callable, name: str = 'abb_plant'):
        self.lock = lock
        self._tick = tick
        self._on_error = on_error
        self._wake = threading.Lock()   # locked: no wake pending; released: wake now
        self._wake.acquire()
        self._stopping = False
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        """Start ticking (the first tick at once)."""
        self._thread.start()

    def wake(self) -> None:
        """Tick now (something the tick depends on changed); harmless when already woken."""
        if self._wake.locked():
            try:
                self._wake.release()
            except RuntimeError:   # released by another waker in between
                pass

    def stop(self, timeout_s: float = 5.0) -> None:
        """Stop the thread and wait for its last tick to end (not from the thread itself)."""
        self._stopping = True
        self.wake()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout_s)

    @property
    def alive(self) -> bool:
        """Whether the thread runs."""
        return self._thread.is_alive()

    def _run(self) -> None:
        name_os_thread(self._thread.name)
        while not self._stopping:
            with self.lock:
                if self._stopping:
                    break
                try:
                    deadline = self._tick()
                except Exception as exc:   # noqa: BLE001 - handed to the node, which stops
                    self._on_error(exc)
                    deadline = IDLE
            if deadline is IDLE:
                self._wake.acquire()
            elif deadline == AGAIN:
                time.sleep(YIELD_S)
            else:
                timeout_s = (deadline - time.monotonic_ns()) * 1e-9
                if timeout_s > 0:   # bounded: a larger timeout raises OverflowError
                    self._wake.acquire(timeout=min(timeout_s, threading.TIMEOUT_MAX))

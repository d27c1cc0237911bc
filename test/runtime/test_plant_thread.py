"""The plant's thread (runtime/plant_thread.py): absolute deadlines, wake-ups, the shared lock.

A plain tick stands for the simulator's; no rclpy. Timing claims are checked loosely (this
machine is shared): the point is that the deadlines are absolute, so a late wake-up is not
carried into the next tick, whatever the scheduler does in between.
"""

import threading
import time

import pytest

from abb_ros.runtime.plant_thread import AGAIN, IDLE, PlantThread, locked

PERIOD_NS = 2_000_000


class Ticks:
    """A tick that asks for ``count`` ticks one period apart from its first, then idles."""

    def __init__(self, count=0, answer=None):
        self.count = count
        self.answer = answer
        self.times = []
        self.first = None
        self.errors = []

    def __call__(self):
        now = time.monotonic_ns()
        self.times.append(now)
        if self.answer is not None:
            return self.answer(self)
        if self.first is None:
            self.first = now
        if len(self.times) >= self.count:
            return IDLE
        return self.first + len(self.times) * PERIOD_NS


def wait_until(predicate, what, timeout_s=10.0):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f'timed out after {timeout_s} s waiting for {what}')
        time.sleep(0.001)


def running(tick):
    thread = PlantThread(tick, threading.RLock(), tick.errors.append)
    thread.start()
    return thread


def test_ticks_follow_absolute_deadlines_so_late_wake_ups_do_not_accumulate():
    """500 ticks asked for one period apart end 499 periods after the first, give or take a
    few periods of scheduling: a relative sleep would add every wake-up's delay (tens of us
    each, about 500 in all here) to the total."""
    tick = Ticks(count=500)
    thread = running(tick)
    try:
        wait_until(lambda: len(tick.times) >= 500, '500 ticks')
        span_ns = tick.times[-1] - tick.first
        assert 499 * PERIOD_NS <= span_ns < 499 * PERIOD_NS + 5 * PERIOD_NS
        assert all(t >= tick.first + k * PERIOD_NS for k, t in enumerate(tick.times))
    finally:
        thread.stop()
    assert not thread.alive


def test_an_idle_thread_ticks_again_only_when_woken():
    tick = Ticks(count=1)
    thread = running(tick)
    try:
        wait_until(lambda: len(tick.times) == 1, 'the first tick')
        time.sleep(0.2)
        assert len(tick.times) == 1, 'an idle thread ticked on its own'
        thread.wake()
        wait_until(lambda: len(tick.times) == 2, 'the tick after wake()')
    finally:
        thread.stop()


def test_a_wake_during_a_long_sleep_ticks_at_once():
    tick = Ticks(answer=lambda _: time.monotonic_ns() + 60_000_000_000)   # a minute away
    thread = running(tick)
    try:
        wait_until(lambda: len(tick.times) == 1, 'the first tick')
        woken = time.monotonic_ns()
        thread.wake()
        wait_until(lambda: len(tick.times) == 2, 'the tick after wake()')
        assert tick.times[1] - woken < 5_000_000_000
    finally:
        thread.stop()


def test_again_ticks_repeatedly_and_lets_a_locked_callback_in_between():
    """As fast as possible (AGAIN), a callback holding the same lock still gets it, and no
    tick runs while it holds it."""
    tick = Ticks(answer=lambda _: AGAIN)
    thread = running(tick)
    inside = []

    def callback():
        before = len(tick.times)
        time.sleep(0.05)
        inside.append(len(tick.times) - before)

    try:
        wait_until(lambda: len(tick.times) > 100, 'ticks')
        for _ in range(5):
            locked(thread.lock, callback)()
        assert inside == [0] * 5
        wait_until(lambda: len(tick.times) > 200, 'more ticks after the callbacks')
    finally:
        thread.stop()


def test_a_tick_that_raises_is_reported_and_the_thread_idles():
    def fail(_tick):
        raise ZeroDivisionError('in the plant')
    tick = Ticks(answer=fail)
    thread = running(tick)
    try:
        wait_until(lambda: tick.errors, 'the error reported')
        time.sleep(0.1)
        assert len(tick.times) == 1 and isinstance(tick.errors[0], ZeroDivisionError)
        assert thread.alive
    finally:
        thread.stop()
    assert not thread.alive


def test_stop_ends_a_thread_that_ticks_as_fast_as_it_can():
    tick = Ticks(answer=lambda _: AGAIN)
    thread = running(tick)
    wait_until(lambda: len(tick.times) > 10, 'ticks')
    thread.stop()
    assert not thread.alive
    count = len(tick.times)
    time.sleep(0.05)
    assert len(tick.times) == count


def test_the_kernel_knows_the_thread_by_its_name():
    """``top -H`` and ``ps -L`` show the plant's thread as abb_plant (Linux)."""
    names = []

    def tick(_t):
        native = threading.get_native_id()
        with open(f'/proc/self/task/{native}/comm') as f:
            names.append(f.read().strip())
        return IDLE
    thread = running(Ticks(answer=tick))
    try:
        wait_until(lambda: names, 'the first tick')
    finally:
        thread.stop()
    assert names == ['abb_plant']

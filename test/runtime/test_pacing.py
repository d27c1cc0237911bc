"""The real-time pacing of the simulator (abb_ros.runtime.pacing) on a fake clock, without DDS.

The node's plant thread calls :meth:`Pacer.due` once per publish period of wall time, at the
deadlines :meth:`Pacer.deadline_ns` gives; here the
steady and the wall clock are one hand-moved counter, so every tick's timing is exact.
"""

import subprocess
import sys

import pytest

from abb_ros.runtime.pacing import Pacer

DT_NS = 100_000            # 10 kHz steps
EVERY = 10                 # 1 kHz publishing
PERIOD_NS = DT_NS * EVERY
START_NS = 1_700_000_000_123_456_789


class FakeClock:
    """A clock that only moves when told to [ns]."""

    def __init__(self, now: int = START_NS):
        self.now = now

    def __call__(self) -> int:
        return self.now

    def advance(self, ns: float) -> None:
        self.now += int(ns)


def pacer(real_time_factor=1.0, max_lag_ns=100e6, clock=None, lead=0.5):
    clock = clock or FakeClock()
    return Pacer(DT_NS, EVERY, real_time_factor, max_lag_ns, clock, clock, lead=lead), clock


def run(p, clock, ticks, steps=0, tick_ns=None):
    """Tick ``ticks`` times one wall period apart, integrating what is due; the new steps."""
    tick_ns = tick_ns or PERIOD_NS / p.real_time_factor
    for _ in range(ticks):
        clock.advance(tick_ns)
        steps += p.due(steps) * EVERY
    return steps


def test_the_pacing_module_imports_without_rclpy():
    code = 'import sys, abb_ros.runtime.pacing; assert "rclpy" not in sys.modules'
    subprocess.run([sys.executable, '-c', code], check=True)


def test_wall_time_stamps_start_at_the_wall_clock_rounded_to_a_step():
    p, _ = pacer(1.0)
    assert not p.publishes_clock
    assert p.epoch_ns == START_NS - START_NS % DT_NS
    assert p.stamp_ns(3) == p.epoch_ns + 3 * DT_NS


@pytest.mark.parametrize('factor', [0.5, 2.0, 0.0])
def test_any_other_factor_stamps_simulated_time_from_0(factor):
    p, _ = pacer(factor)
    assert p.publishes_clock and p.epoch_ns == 0 and p.stamp_ns(7) == 7 * DT_NS


@pytest.mark.parametrize('factor', [1.0, 0.5, 4.0])
def test_each_tick_on_time_integrates_exactly_one_period(factor):
    p, clock = pacer(factor)
    p.start(0)
    assert p.tick_period_s == pytest.approx(PERIOD_NS / factor * 1e-9)
    for k in range(1, 200):
        clock.advance(PERIOD_NS / factor)
        assert p.due((k - 1) * EVERY) == 1
    assert p.overruns == 0 and p.slips == 0


def test_jitter_below_half_a_period_either_way_still_gives_one_period_per_tick():
    p, clock = pacer(1.0)
    p.start(0)
    steps = 0
    for k in range(100):
        clock.advance(PERIOD_NS + (0.45 if k % 2 else -0.45) * PERIOD_NS)
        periods = p.due(steps)
        steps += periods * EVERY
        assert periods == 1
    assert p.overruns == 0


@pytest.mark.parametrize('lead', [0.0, 0.5])
@pytest.mark.parametrize('factor', [1.0, 0.5, 4.0])
def test_ticks_at_the_deadlines_integrate_one_period_each_and_stamps_never_lead_the_wall(
        factor, lead):
    """The plant thread sleeps until deadline_ns: each wake-up there integrates one period,
    and on the wall clock that period's last stamp is not after the wake-up (no stamp in the
    future), and at most a period before it (with lead 0: at it, give or take the rounding of
    the epoch to a step)."""
    p, clock = pacer(factor, lead=lead)
    p.start(0)
    steps = 0
    for _ in range(300):
        deadline = p.deadline_ns(steps)
        assert deadline > clock.now
        clock.now = deadline
        assert p.due(steps) == 1
        steps += EVERY
        if factor == 1.0:
            assert 0 <= clock.now - p.stamp_ns(steps) < (PERIOD_NS if lead else DT_NS)
    assert p.overruns == 0 and p.slips == 0
    assert clock.now - START_NS == pytest.approx(300 * PERIOD_NS / factor, abs=2)


def test_with_lead_0_a_wake_up_late_by_less_than_a_period_publishes_one_period_late():
    """The plant thread's sleeps never end early, so with lead 0 a period is due at its stamp:
    a wake-up 0.9 period late integrates that period alone (no overrun, nothing published
    ahead of its stamp), and the next deadline is the next stamp."""
    p, clock = pacer(1.0, lead=0.0)
    p.start(0)
    steps = 0
    for k in range(100):
        late = (0.9 if k % 3 == 0 else 0.0) * PERIOD_NS
        clock.now = p.deadline_ns(steps) + int(late)
        assert p.due(steps) == 1
        steps += EVERY
        assert 0 <= clock.now - p.stamp_ns(steps) - int(late) < DT_NS   # epoch rounding
    assert p.overruns == 0


def test_the_deadline_after_a_slip_follows_the_new_schedule():
    p, clock = pacer(1.0, max_lag_ns=3 * PERIOD_NS)
    p.start(0)
    steps = run(p, clock, 10)
    clock.advance(20 * PERIOD_NS)            # a stall: dropped as a slip
    assert p.due(steps) == 1 and p.slips == 1
    steps += EVERY
    deadline = p.deadline_ns(steps)
    assert 0 < deadline - clock.now <= PERIOD_NS
    clock.now = deadline
    assert p.due(steps) == 1


def test_a_late_tick_catches_up_and_counts_overruns():
    p, clock = pacer(1.0)
    p.start(0)
    steps = run(p, clock, 10)
    clock.advance(5 * PERIOD_NS)            # 4 periods late: 5 due at this tick
    periods = p.due(steps)
    assert periods == 5 and p.overruns == 4 and p.slips == 0


def test_lag_with_wall_time_stamps_is_behind_the_wall_clock():
    p, clock = pacer(1.0)
    p.start(0)
    steps = run(p, clock, 10)
    clock.advance(4 * PERIOD_NS)
    p.due(steps)
    first = steps + EVERY
    assert p.lag_ns == clock.now - p.stamp_ns(first)
    assert p.lag_max_ns == p.lag_ns


def test_lag_with_simulated_stamps_is_behind_the_schedule():
    p, clock = pacer(0.5)
    p.start(0)
    steps = run(p, clock, 10)
    clock.advance(3 * PERIOD_NS / 0.5)
    periods = p.due(steps)
    assert periods == 3
    # The tick's first stamp is one period after 'steps'; the schedule is 3.5 periods after
    # it (due half a period ahead): 2.5 publish periods behind, in wall time at factor 0.5.
    assert p.lag_ns == int(2.5 * PERIOD_NS / 0.5)


def test_a_lag_beyond_max_lag_drops_the_missed_periods_as_a_slip():
    p, clock = pacer(1.0, max_lag_ns=20e6)
    p.start(0)
    steps = run(p, clock, 10)
    epoch = p.epoch_ns
    clock.advance(50 * PERIOD_NS)          # a stall: 50 periods due, 49 of them dropped
    periods = p.due(steps)
    assert periods == 1 and p.slips == 1 and p.overruns == 49
    assert p.slipped_ns == 49 * PERIOD_NS
    assert p.epoch_ns == epoch + 49 * PERIOD_NS      # wall-time stamps jump forward
    steps += EVERY
    assert p.lag_ns < PERIOD_NS                      # the slipped tick's stamp is on time
    assert run(p, clock, 10, steps) == steps + 10 * EVERY   # paced from now on
    assert p.slips == 1


def test_a_slip_with_simulated_stamps_keeps_simulated_time_going_on():
    p, clock = pacer(2.0, max_lag_ns=20e6)
    p.start(0)
    steps = run(p, clock, 10)
    clock.advance(100 * PERIOD_NS / 2.0)
    assert p.due(steps) == 1 and p.slips == 1 and p.epoch_ns == 0
    assert p.slipped_ns == int(99 * PERIOD_NS / 2.0)


def test_a_stall_within_max_lag_is_caught_up_not_slipped():
    p, clock = pacer(1.0, max_lag_ns=100e6)
    p.start(0)
    steps = run(p, clock, 10)
    clock.advance(30 * PERIOD_NS)
    assert p.due(steps) == 30 and p.slips == 0 and p.overruns == 29


def test_after_a_pause_wall_time_stamps_jump_to_the_wall_clock_never_back():
    p, clock = pacer(1.0)
    p.start(0)
    steps = run(p, clock, 10)
    clock.advance(2_000_000_000)           # paused for 2 s: no ticks
    p.start(steps)
    assert 0 <= clock.now - p.stamp_ns(steps) < DT_NS
    assert run(p, clock, 5, steps) == steps + 5 * EVERY
    epoch = p.epoch_ns
    p.start(steps + 5 * EVERY + 30 * EVERY)     # stamps ahead of the wall clock: kept
    assert p.epoch_ns == epoch


def test_after_a_pause_simulated_stamps_go_on_from_where_they_were():
    p, clock = pacer(0.5)
    p.start(0)
    steps = run(p, clock, 10)
    clock.advance(2_000_000_000)
    p.start(steps)
    assert p.epoch_ns == 0
    assert p.due(steps) == 0                  # the schedule starts again at the resume
    assert run(p, clock, 5, steps) == steps + 5 * EVERY


def test_a_factor_change_restarts_the_schedule_at_the_new_rate():
    p, clock = pacer(1.0)
    p.start(0)
    steps = run(p, clock, 10)
    p.reconfigure(4.0, EVERY, p.max_lag_ns)
    p.start(steps)
    assert p.publishes_clock                   # wall-clock stamps only at factor 1
    assert p.tick_period_s == pytest.approx(PERIOD_NS / 4.0 * 1e-9)
    assert run(p, clock, 8, steps) == steps + 8 * EVERY
    clock.advance(PERIOD_NS)                  # four ticks' worth at factor 4
    assert p.due(steps + 8 * EVERY) == 4


def test_factor_0_is_not_paced_and_publishes_clock():
    p, clock = pacer(0.0)
    p.start(0)                                 # no anchor, no jump: as fast as possible
    assert p.publishes_clock and p.epoch_ns == 0
    clock.advance(10 * PERIOD_NS)
    window = p.close_window(100_000, True)   # 10 s simulated in 10 ms of wall time
    assert window.real_time_factor == pytest.approx(1000.0)


def test_the_diagnostics_window_measures_the_achieved_factor_and_resets_lag_and_slips():
    p, clock = pacer(1.0, max_lag_ns=20e6)
    p.start(0)
    p.start_window(0)
    steps = run(p, clock, 100)
    clock.advance(50 * PERIOD_NS)
    steps += p.due(steps) * EVERY              # a slip: 49 periods dropped
    window = p.close_window(steps, running=False)
    assert window.slips == 1 and 0 < window.stamp_lag < PERIOD_NS * 1e-9
    assert window.real_time_factor == pytest.approx(101 / 150)
    assert window.since_start == pytest.approx(101 / 150)
    again = p.close_window(steps, running=True)
    assert again.slips == 0 and again.stamp_lag == 0.0


def test_paused_windows_do_not_count_for_the_factor_since_start():
    p, clock = pacer(1.0)
    p.start(0)
    p.start_window(0)
    steps = run(p, clock, 100)
    first = p.close_window(steps, running=False)      # paused from now on
    clock.advance(1_000_000_000)
    paused = p.close_window(steps, running=True)
    assert first.real_time_factor == pytest.approx(1.0)
    assert paused.real_time_factor == 0.0
    assert paused.since_start == pytest.approx(1.0)


# ---- the time rule (abb_ros.runtime.sim_clock): every transition on the fake clock --------------

def run_at(p, clock, factor, ticks, steps):
    """Set ``factor``, restart the pacing as the node does, tick ``ticks`` periods."""
    p.reconfigure(factor, EVERY, p.max_lag_ns)
    p.start(steps)
    return run(p, clock, ticks, steps)


def test_after_a_speed_up_stamps_never_go_back_and_clock_carries_them_for_good():
    p, clock = pacer(1.0)
    p.start(0)
    steps = run(p, clock, 100)
    assert not p.publishes_clock and p.clock.on_wall
    steps = run_at(p, clock, 2.0, 8000, steps)     # 4 s of wall time at factor 2: 8 s simulated
    assert p.publishes_clock and not p.clock.on_wall
    ahead = p.stamp_ns(steps) - clock.now
    assert ahead > 3.9e9                           # simulated time is 4 s ahead of the wall
    before = p.stamp_ns(steps)
    steps = run_at(p, clock, 1.0, 1000, steps)     # back at factor 1 for 1 s
    assert p.stamp_ns(steps) == before + 1_000_000_000    # continuous: no jump back
    assert p.publishes_clock and not p.clock.on_wall      # /clock carries the stamps
    assert p.stamp_ns(steps) - clock.now == pytest.approx(ahead, abs=PERIOD_NS)


def test_after_a_slow_down_stamps_rejoin_the_wall_clock_and_clock_stays():
    p, clock = pacer(1.0)
    p.start(0)
    steps = run(p, clock, 100)
    steps = run_at(p, clock, 0.5, 2000, steps)     # 4 s of wall time: 2 s simulated
    assert clock.now - p.stamp_ns(steps) > 1.9e9
    p.reconfigure(1.0, EVERY, p.max_lag_ns)
    p.start(steps)
    assert 0 <= clock.now - p.stamp_ns(steps) < DT_NS     # jumped forward to the wall
    assert p.clock.on_wall and p.publishes_clock          # /clock never goes silent again


@pytest.mark.parametrize('factor', [1.0, 3.0])
def test_a_pause_publishes_clock_for_good_and_the_resume_at_1_rejoins_the_wall(factor):
    p, clock = pacer(1.0)
    p.start(0)
    steps = run_at(p, clock, factor, 100, 0)
    p.hold()                                      # paused (or a fault)
    assert p.publishes_clock and not p.clock.on_wall
    steps += 3 * EVERY                            # three ~/step calls while paused
    clock.advance(2_000_000_000)
    steps = run_at(p, clock, 1.0, 10, steps)      # resumed at factor 1
    assert p.publishes_clock and p.clock.on_wall
    assert 0 <= clock.now - p.stamp_ns(steps) <= PERIOD_NS


def test_started_paused_the_clock_is_published_from_the_start():
    p, clock = pacer(1.0)
    p.hold()                                      # start_paused
    assert p.publishes_clock and p.epoch_ns == START_NS - START_NS % DT_NS
    clock.advance(1_000_000_000)
    p.start(EVERY)                                # resumed: the stamps rejoin the wall clock
    assert p.clock.on_wall and 0 <= clock.now - p.stamp_ns(EVERY) < DT_NS


def test_a_rate_change_at_factor_1_keeps_the_wall_clock_and_no_clock():
    p, clock = pacer(1.0)
    p.start(0)
    steps = run(p, clock, 100)
    p.reconfigure(1.0, 2 * EVERY, p.max_lag_ns)   # publish rate halved: no departure
    p.start(steps)
    assert not p.publishes_clock and p.clock.on_wall


def test_simulated_time_from_0_never_follows_the_wall_clock():
    p, clock = pacer(2.0)
    p.start(0)
    steps = run(p, clock, 100)
    steps = run_at(p, clock, 1.0, 100, steps)
    assert p.epoch_ns == 0 and not p.clock.on_wall and p.publishes_clock
    assert p.stamp_ns(steps) == steps * DT_NS


def test_a_slip_ahead_of_the_wall_clock_does_not_move_the_stamps():
    p, clock = pacer(1.0, max_lag_ns=20e6)
    p.start(0)
    steps = run_at(p, clock, 2.0, 1000, 0)
    steps = run_at(p, clock, 1.0, 10, steps)
    epoch = p.epoch_ns
    clock.advance(50 * PERIOD_NS)                 # a stall: dropped, stamps go on
    assert p.due(steps) == 1 and p.slips == 1 and p.epoch_ns == epoch

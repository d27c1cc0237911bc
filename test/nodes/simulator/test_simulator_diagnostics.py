"""The level and message of the simulator's /diagnostics status, without DDS."""

import pytest
from diagnostic_msgs.msg import DiagnosticStatus

from abb_ros.nodes.simulator.diagnostics import level_and_message
from abb_ros.runtime.pacing import PacingWindow

OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR
ON_TIME = PacingWindow(real_time_factor=1.0, since_start=1.0, stamp_lag=0.0002, slips=0)


def status(window=ON_TIME, **kwargs):
    return level_and_message(window, **kwargs)


def test_running_on_time_is_ok_with_the_achieved_factor():
    assert status() == (OK, 'running at real_time_factor 1.000')


def test_below_90_percent_of_the_target_warns_with_the_target():
    slow = PacingWindow(0.85, 0.9, 0.0, 0)
    assert status(slow) == (WARN, 'running at real_time_factor 0.850 (target 1)')
    assert status(slow, target=0.9)[0] == OK
    assert status(PacingWindow(5.0, 5.0, 0.0, 0), target=0.0)[0] == OK   # as fast as possible


def test_stamps_later_than_a_period_warn_and_beyond_max_stamp_lag_are_an_error():
    late = PacingWindow(1.0, 1.0, 0.0042, 0)
    level, message = status(late, period_s=1e-3, max_lag_ns=0.1e9)
    assert level == WARN
    assert message.endswith('; stamps up to 4.2 ms late (publish period 1 ms)')
    assert status(late, period_s=1e-3, max_lag_ns=0.004e9)[0] == ERROR


def test_slips_are_an_error_with_the_time_dropped():
    slipped = PacingWindow(0.7, 0.95, 0.0004, 2)
    level, message = status(slipped, slipped_s=0.25)
    assert level == ERROR
    assert message == ('running at real_time_factor 0.700 (target 1); cannot keep up: 2 '
                       'slip(s), stamps more than max_stamp_lag late were dropped (0.250 s '
                       'in all)')


def test_a_fault_is_an_error_and_paused_is_ok():
    assert status(fault='non-finite output at t = 1.0 s') == (
        ERROR, 'non-finite output at t = 1.0 s')
    assert status(paused=True) == (OK, 'paused')
    assert status(PacingWindow(0.0, 1.0, 0.0, 0), paused=True) == (OK, 'paused')


@pytest.mark.parametrize('kwargs, tail', [
    (dict(recording_error='No space left on device'),
     '; recording stopped: No space left on device'),
    (dict(fg_min_speed=12.5),
     '; spindle/speed reads 0: the spindle turns below the FG minimum 12.500 rad/s'),
    (dict(contact_note='contact steps refined'), '; contact steps refined'),
])
def test_recording_fg_and_contact_notes_warn_at_least(kwargs, tail):
    level, message = status(**kwargs)
    assert level == WARN and message == 'running at real_time_factor 1.000' + tail
    level, message = status(fault='stopped', **kwargs)
    assert level == ERROR and message == 'stopped' + tail

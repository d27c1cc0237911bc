"""The simulator's ``<node>: simulation`` status on /diagnostics: level, message and values.

:func:`level_and_message` is a pure function of what the status reports (tested without
DDS in test/nodes/simulator/test_simulator_diagnostics.py);
:func:`simulation_status` reads it, and the
key/value list, from the node once per diagnostics period.
"""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticStatus

from abb_ros.runtime.pacing import PacingWindow

__all__ = ['level_and_message', 'simulation_status']


def level_and_message(window: PacingWindow, *, fault: str = '', paused: bool = False,
                      target: float = 1.0, period_s: float = 1e-3, max_lag_ns: float = 1e8,
                      slipped_s: float = 0.0, recording_error: str = '',
                      fg_min_speed: float | None = None, contact_note: str = ''
                      ) -> tuple[bytes, str]:
    """Say how the simulation runs: the level and message of its status.

    Parameters
    ----------
    window : PacingWindow
        How the plant kept pace over the window.
    fault : str
        The fault that stopped the plant ('' none): ERROR.
    paused : bool
        Paused by ``~/pause``: OK.
    target : float
        The real_time_factor asked for; WARN when the window achieved less than 90 % of it.
    period_s : float
        Publish period [s]; WARN when the stamps were later than that.
    max_lag_ns : float
        ``max_stamp_lag`` [ns]: a stamp later than that is an ERROR.
    slipped_s : float
        Wall time dropped by slips since start [s].
    recording_error : str
        Why the recording stopped ('' none): WARN.
    fg_min_speed : float or None
        The FG's minimum speed [rad/s] when it reads 0 with the spindle turning below it
        (WARN), else None.
    contact_note : str
        The contact step-size note of the simulation ('' none): WARN.

    Returns
    -------
    level : bytes
        The DiagnosticStatus level: the worst of the conditions above.
    message : str
        One line: how the run goes, then each warning, joined by '; '.
    """
    lag, slips = window.stamp_lag, window.slips
    if fault:
        level, message = DiagnosticStatus.ERROR, fault
    elif paused:
        level, message = DiagnosticStatus.OK, 'paused'
    else:
        achieved = window.real_time_factor
        behind = target > 0 and achieved < 0.9 * target
        level = DiagnosticStatus.WARN if behind or lag > period_s else DiagnosticStatus.OK
        message = (f'running at real_time_factor {achieved:.3f}'
                   + (f' (target {target:g})' if behind else ''))
        if slips:
            level = DiagnosticStatus.ERROR
            message += (f'; cannot keep up: {slips} slip(s), stamps more than '
                        f'max_stamp_lag late were dropped ({slipped_s:.3f} s in all)')
        elif lag > period_s:
            message += (f'; stamps up to {lag * 1e3:.1f} ms late (publish period '
                        f'{period_s * 1e3:g} ms)')
            if lag * 1e9 > max_lag_ns:
                level = DiagnosticStatus.ERROR   # one late period, nothing to drop
    if recording_error:
        level = max(level, DiagnosticStatus.WARN)
        message += f'; recording stopped: {recording_error}'
    if fg_min_speed is not None:
        level = max(level, DiagnosticStatus.WARN)
        message += (f'; spindle/speed reads 0: the spindle turns below the FG minimum '
                    f'{fg_min_speed:.3f} rad/s')
    if contact_note:
        level = max(level, DiagnosticStatus.WARN)
        message += f'; {contact_note}'
    return level, message


def simulation_status(node, window: PacingWindow) -> tuple[bytes, str, dict]:
    """(level, message, values) of :class:`abb_ros.nodes.simulator.node.SimulatorNode` ``node``.

    The values: real_time_factor achieved over the window and since start, the stamp lag
    and slips, counters, the plant's state, the FG's state, recording and publishing counts.
    """
    sim, pacer, settings = node.sim, node.pacer, node.settings
    fg = node.hil.speed
    fg_state = fg.state(sim.omega)
    max_stamp_lag = settings.max_stamp_lag
    recording = node.recorder.current
    level, message = level_and_message(
        window, fault=node.fault, paused=node.paused, target=pacer.real_time_factor,
        period_s=pacer.publish_every * pacer.dt_ns * 1e-9, max_lag_ns=pacer.max_lag_ns,
        slipped_s=pacer.slipped_ns * 1e-9,
        recording_error=node.recorder.error,
        fg_min_speed=(fg.min_speed if fg_state == 'below_min_speed' and fg.value == 0.0
                      else None),
        contact_note=sim.contact_step_note)
    values = dict(real_time_factor=window.real_time_factor,
                  real_time_factor_since_start=window.since_start,
                  target_real_time_factor=pacer.real_time_factor, stamp_lag=window.stamp_lag,
                  stamp_lag_max=pacer.lag_max_ns * 1e-9, max_stamp_lag=max_stamp_lag,
                  time_base=pacer.clock.time_base, scheduling=node.scheduling.state,
                  overruns=pacer.overruns, slips=pacer.slips, **node.counters,
                  slipped_time=pacer.slipped_ns * 1e-9,
                  steps=sim.steps, sim_time=sim.t, rbar=sim.rbar, omega=sim.omega,
                  wbar=node.drive.wbar(sim.omega), speed_cmd=node.speed_cmd,
                  spindle_mode=settings.spindle_mode,
                  fg_state=fg_state, fg_min_speed=fg.min_speed,
                  n=node.drive.n, paused=node.paused, fault=node.fault,
                  contact_refined_steps=sim.refined_steps,
                  rolling_switches=sim.rolling_switches,
                  recording=str(recording.bag.path) if recording is not None else '',
                  recorded=recording.message_count if recording is not None else 0,
                  recording_lost=recording.lost_count if recording is not None else 0,
                  **{f'published {t}': count for t, count in node.published.items()})
    if node.ros2_control is not None:
        values.update(node.ros2_control.values())
    if settings.spindle_mode == 'torque':
        values.update(current_cmd=node.current_cmd, motor_current=sim.motor_current,
                      motor_torque=sim.motor_torque)
    return level, message, values

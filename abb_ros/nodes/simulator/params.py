"""The simulator node's parameters: the plant's, and those only the node has.

:data:`SIMULATOR_SPECS` is the node's list, in declaration order: the drive is declared
first (:mod:`abb_ros.model.parameters.drive_spec`), then these. The plant's parameters (rates,
spindle, seed, IMU, motor; :mod:`abb_ros.model.parameters.plant_spec`) are shared with ``abb-sim
run``; pacing, the HIL I/O (FG speed sensor, faults, disturbances, markers), recording, the live
view and the ros2_control bridge are the node's own.
"""

from __future__ import annotations

import math

from abb_ros.io.live_view.admission import DEFAULT_ALLOWED_ORIGINS, DEFAULT_HOST, DEFAULT_PORT
from abb_ros.io.live_view.rate_cap import DEFAULT_MAX_RATE_HZ
from abb_ros.io.wire.topics import CURRENT_CMD, DIAGNOSTICS, SPEED_CMD, STABILITY_MARGIN
from abb_ros.model.parameters.drive_spec import MAX_OMEGA
from abb_ros.model.parameters.param_spec import (
    BOOL,
    DOUBLE_ARRAY,
    INTEGER,
    STRING,
    STRING_ARRAY,
    ParamSpec,
)
from abb_ros.model.parameters.plant_spec import (
    IMU_FULL_SCALE,
    IMU_SPECS,
    MAX_SPINDLE_SPEED,
    MOTOR_SPECS,
    SEED,
    SPINDLE_SPECS,
    STEP_SPECS,
)

__all__ = ['LIVE_VIEW_TOPICS', 'MIN_REAL_TIME_FACTOR', 'REAL_TIME_FACTOR_VALID',
           'SIMULATOR_SPECS', 'SPINDLE_MODE']

_AT_STEP = 'at the next step'
_A_MAX, _G_MAX = IMU_FULL_SCALE

MIN_REAL_TIME_FACTOR = 1e-6
"""Smallest real_time_factor above 0: a publish period of 1 s (publish_rate_hz 1) then lasts
1e6 s of wall time, within what the plant thread's clock waits for (threading.TIMEOUT_MAX);
smaller factors overflowed it (time_t) or, below 1e-308, made the deadline NaN."""
REAL_TIME_FACTOR_VALID = f'0 (as fast as possible) or [{MIN_REAL_TIME_FACTOR:g}, 1000]'
"""What real_time_factor may be, as a refusal says it."""

_PACING = (
    ParamSpec('real_time_factor', 1.0, '', 'simulated seconds per wall second (1 = wall '
              f'clock, HIL); 0 = as fast as possible; else at least {MIN_REAL_TIME_FACTOR:g} '
              '(what the pacing clock can wait for)', low=0.0, high=1000.0, applies=_AT_STEP),
    ParamSpec('start_paused', False, '', 'start with integration paused (use ~/pause, ~/step)',
              BOOL, read_only=True, applies='at start-up'),
)

_BENCH = (
    # FG speed sensor, faults, disturbances, markers (nodes/simulator/hil_settings.py),
    # pacing limits, recording
    ParamSpec('speed_sensor.pulses_per_rev', 6, '', 'FG pulses per spindle revolution (3 per '
              'pole pair of a BLDC motor)', INTEGER, 1, 1000, applies='on ~/reset'),
    ParamSpec('speed_sensor.timer_hz', 1.0e6, 'Hz', 'FG edge capture timer clock '
              '(quantisation); 1 Hz to 10 GHz (above any microcontroller capture timer; a '
              'finite tick count for any edge time)', low=1.0, high=1e10,
              applies='on ~/reset'),
    ParamSpec('speed_sensor.edge_jitter', 1.0e-6, 's', 'FG edge time jitter, standard '
              'deviation; at most 1 s (beyond timeout, every reading is noise)', low=0.0,
              high=1.0, applies='on ~/reset'),
    ParamSpec('speed_sensor.timeout', 0.1, 's', 'no FG edge for this long reads 0 rad/s: '
              'below 2 pi / (pulses_per_rev timeout), 10.47 rad/s by default, the reading drops '
              'to 0 between edges; at most 1 hour',
              low=0.0, low_open=True, high=3600.0, applies='on ~/reset'),
    ParamSpec('speed_sensor.pitch_error', 0.0, 'rad', 'FG pole-pitch error, RMS over the '
              'edges of a revolution: a zero-mean pattern drawn from the seed, repeating every '
              'revolution; below pi / pulses_per_rev^1.5', low=0.0, high=math.pi,
              applies='on ~/reset'),
    ParamSpec('fault.imu_dropout', False, '', 'IMU dropout: no deck/imu messages while true',
              BOOL, applies=_AT_STEP),
    ParamSpec('fault.imu_stuck', False, '', 'IMU stuck: deck/imu repeats its last reading '
              'while true', BOOL, applies=_AT_STEP),
    ParamSpec('fault.imu_accel_bias_step', [0.0, 0.0, 0.0], 'm/s^2', 'bias step added to '
              'deck/imu specific force, deck axes; each within the full scale IMU_FULL_SCALE '
              '(a saturated reading, finite)', DOUBLE_ARRAY, length=3, low=-_A_MAX,
              high=_A_MAX, applies=_AT_STEP),
    ParamSpec('fault.imu_gyro_bias_step', [0.0, 0.0, 0.0], 'rad/s', 'bias step added to '
              'deck/imu angular rate, deck axes; each within the full scale IMU_FULL_SCALE',
              DOUBLE_ARRAY, length=3, low=-_G_MAX, high=_G_MAX, applies=_AT_STEP),
    ParamSpec('fault.speed_dropout', False, '', 'speed sensor dropout: no spindle/speed while '
              'true', BOOL, applies=_AT_STEP),
    ParamSpec('fault.speed_noise', 0.0, 'rad/s', 'white noise added to spindle/speed, std; at '
              'most the model\'s speed limit MAX_OMEGA (a draw of 1e308 rad/s read as inf)',
              low=0.0, high=MAX_OMEGA, applies=_AT_STEP),
    ParamSpec('disturbance.shock_velocity', [0.0] * 6, 'm/s, rad/s', 'deck twist step of '
              '~/apply_shock, deck axes [vx, vy, vz, wx, wy, wz]; each at most 1000 (the deck '
              'leaves its 20 mm envelope within 20 us: ERROR, never a non-finite state)',
              DOUBLE_ARRAY, length=6, low=-1000.0, high=1000.0, applies='on ~/apply_shock'),
    ParamSpec('disturbance.disc_eps', 0.25e-3, 'm', 'eccentricity eps of the disc put in by '
              '~/swap_disc (becomes drive.eps)', low=0.0, high=1.0, applies='on ~/swap_disc'),
    ParamSpec('disturbance.disc_angle_deg', 0.0, 'deg', 'imbalance angle of the disc put in '
              'by ~/swap_disc, relative to the current one', low=-360.0, high=360.0,
              applies='on ~/swap_disc'),
    ParamSpec('visualization.rate_hz', 20.0, 'Hz', 'visualization/markers rate, simulated '
              'time; 0 = off', low=0.0, high=1000.0, applies=_AT_STEP),
    ParamSpec('visualization.exaggeration', 100.0, '', 'deck displacement and tilt scale '
              'factor in visualization/markers', low=0.0, high=1.0e6, applies=_AT_STEP),
    ParamSpec('joint_states_throttle_hz', 50.0, 'Hz', 'joint_states_throttle rate, simulated '
              'time: every joint_states message opening a slot of 1 / rate (for readers that '
              'need the latest state, not each: the analysis node); 0 = off', low=0.0,
              high=1000.0, applies=_AT_STEP),
    ParamSpec('max_stamp_lag', 0.1, 's', 'largest lag of a stamp behind its schedule (the wall '
              'clock at real_time_factor 1); a later plant drops the excess (counted in slips) '
              'and reports ERROR', low=0.001, high=3600.0, applies=_AT_STEP),
    ParamSpec('realtime_priority', 0, '', 'SCHED_FIFO priority of the integrating thread '
              'while paced (real_time_factor > 0); 0 = the normal scheduler. Needs '
              'CAP_SYS_NICE or an rtprio limit; refused: one warning, normal scheduler',
              INTEGER, 0, 99, applies=_AT_STEP),
    ParamSpec('record.path', '', '', 'bag directory the node records what it publishes to '
              '(must not exist); empty: no recording at start (~/start_recording uses it, or '
              'abb_bag_<date>-<time>)', STRING, applies='at start-up'),
    ParamSpec('record.start', False, '', 'record from start-up, to record.path, else to '
              'abb_bag_<date>-<time> (a non-empty record.path records from start-up too)',
              BOOL, read_only=True, applies='at start-up'),
    ParamSpec('record.topics', [], '', "other topics recorded into the node's bag, taken from "
              'the middleware as the recorder node takes them (e.g. stability/margin, '
              '/diagnostics, spindle/speed_cmd); a topic this node also publishes is then '
              "recorded from the middleware with the others' messages", STRING_ARRAY,
              applies='at start-up'),
)

LIVE_VIEW_TOPICS = (STABILITY_MARGIN, DIAGNOSTICS, SPEED_CMD,
                    CURRENT_CMD)
"""The bench's topics other nodes publish, which the live view serves by default."""

_LIVE_VIEW = (
    # the Foxglove WebSocket server (nodes/simulator/live_view.py, docs/ros_api.md)
    ParamSpec('live_view.enabled', False, '', 'serve what the node publishes on a Foxglove '
              'WebSocket server (the Foxglove app: Open connection, Foxglove WebSocket, '
              'ws://live_view.host:live_view.port), with pause, step, reset, the spindle '
              'commands and the parameters from the viewer', BOOL, read_only=True,
              applies='at start-up'),
    ParamSpec('live_view.host', DEFAULT_HOST, '', 'address the live view listens on (loopback: '
              'this machine only, and a handshake must name loopback in its Host; 0.0.0.0: '
              'every interface, with no authentication; empty or unresolvable: refused)', STRING,
              read_only=True, applies='at start-up'),
    ParamSpec('live_view.port', DEFAULT_PORT, '', 'port of the live view; 0 = any free port '
              '(logged)', INTEGER, 0, 65535, read_only=True, applies='at start-up'),
    ParamSpec('live_view.topics', list(LIVE_VIEW_TOPICS), '', "other nodes' topics served "
              'too, taken from the middleware once a publisher offers them (the analysis '
              "node's stability/margin of the Foxglove layout, /diagnostics, the spindle "
              'commands)', STRING_ARRAY, read_only=True, applies='at start-up'),
    ParamSpec('live_view.allowed_origins', list(DEFAULT_ALLOWED_ORIGINS), '', 'browser origins '
              'that may connect to the live view (scheme://host[:port], each part a shell '
              'pattern, * = any; a handshake with '
              'another Origin gets HTTP 403, one without Origin, from a client that is not a '
              'browser, is taken): the Foxglove web app, desktop apps (file://) and pages '
              'served from this machine', STRING_ARRAY, read_only=True, applies='at start-up'),
    ParamSpec('live_view.max_rate_hz', DEFAULT_MAX_RATE_HZ, 'Hz', 'most messages of one topic '
              'the live view sends a second (simulated time: the first of each slot of '
              '1 / rate), so that a browser viewer keeps up; the ROS topics and bags keep '
              'every one; 0 = every message', low=0.0, high=1.0e6, read_only=True,
              applies='at start-up'),
)

_ROS2_CONTROL = (
    # ros2_control's topic-based system (nodes/simulator/ros2_control.py, docs/ros_api.md)
    ParamSpec('ros2_control.enabled', False, '', "take commands from ros2_control's "
              'topic-based system (joint_state_topic_hardware_interface/JointStateTopicSystem): '
              "the spindle entry's velocity (speed) or effort (torque mode) on "
              'ros2_control.joint_commands_topic; joint_states copied to '
              'ros2_control.joint_states_topic (sensor-data QoS)', BOOL, read_only=True,
              applies='at start-up'),
    ParamSpec('ros2_control.joint_commands_topic', '/robot_joint_commands', '', 'the '
              "system's joint_commands_topic (sensor_msgs/JointState, reliable)", STRING,
              read_only=True, applies='at start-up'),
    ParamSpec('ros2_control.joint_states_topic', '/robot_joint_states', '', "the system's "
              'joint_states_topic (sensor_msgs/JointState, sensor-data QoS)', STRING,
              read_only=True, applies='at start-up'),
)

SPINDLE_MODE = ParamSpec(
    'spindle.mode', 'speed', '', 'speed: theta prescribed, spindle/speed_cmd through the '
    'speed loop above; torque: theta free, driven by the motor.* motor from '
    'spindle/current_cmd (docs/torque_mode.md)', STRING, choices=('speed', 'torque'),
    applies=_AT_STEP)
"""How the spindle is driven: by the speed loop or by the motor's torque."""


SIMULATOR_SPECS = (*STEP_SPECS, *_PACING, MAX_SPINDLE_SPEED, *SPINDLE_SPECS, SEED, *_BENCH,
                   *_LIVE_VIEW, *_ROS2_CONTROL, *IMU_SPECS, SPINDLE_MODE, *MOTOR_SPECS)
"""The simulator node's parameters besides ``drive.*`` (config/simulator.yaml)."""

"""The example controller's own parameters (besides ``drive.*``, ``motor.*``).

The controller also declares the drive's parameters, ``max_spindle_speed`` and the motor's
(:mod:`abb_ros.model.parameters.drive_spec`, :mod:`abb_ros.model.parameters.plant_spec`);
:data:`CONTROLLER_SPECS` are the ones only it has.
"""

from __future__ import annotations

from abb_ros.model.parameters.drive_spec import MAX_OMEGA
from abb_ros.model.parameters.param_spec import INTEGER, STRING, ParamSpec

__all__ = ['CONTROLLER_SPECS']


CONTROLLER_SPECS = (
    ParamSpec('target_speed', None, 'rad/s', 'speed to reach and hold; default wbar = 2.7 (P3) '
              'with the drive omega0; at most the model\'s speed limit MAX_OMEGA', low=0.0,
              high=MAX_OMEGA, applies='at once'),
    ParamSpec('acceleration', 500.0, 'rad/s^2', 'run-up acceleration of the reference outside '
              'the unbalanced bands (inside them the drive\'s own limit applies); at most '
              '1e9 (MAX_OMEGA within 0.1 ms)', low=1e-3, high=1e9, applies='at once'),
    ParamSpec('kp', 0.0, '', 'proportional gain on the speed error (command correction per '
              'rad/s); 0: trust the drive\'s own speed loop', low=0.0, high=100.0,
              applies='at once'),
    ParamSpec('ki', 0.0, '1/s', 'integral gain on the speed error while holding, for a drive '
              'whose speed loop leaves a steady error', low=0.0, high=1000.0, applies='at once'),
    ParamSpec('mode', 'speed', '', 'command mode: speed (spindle/speed_cmd; kp, ki) or '
              'torque (spindle/current_cmd from the speed loop; loop_bandwidth, motor.*)',
              STRING, choices=('speed', 'torque'), read_only=True, applies='at start-up'),
    ParamSpec('loop_bandwidth', 60.0, 'rad/s', 'torque mode: crossover of the speed loop '
              '(kp = (J_z + I_r) wc / K_t, ki = kp wc / 4)', low=0.0, low_open=True,
              high=1e4, applies='at once'),
    ParamSpec('guard_wbar', 0.1, '', 'distance kept from an unbalanced band, in wbar',
              low=0.0, high=1.0, read_only=True, applies='at start-up'),
    ParamSpec('table_points', 300, '', 'speeds in the band table over 0..max_spindle_speed',
              INTEGER, 16, 20000, read_only=True, applies='at start-up'),
)
"""The example controller's parameters (spin_controller)."""


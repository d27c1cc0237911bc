"""The spindle commands the simulator takes: the last valid ones, and what was refused.

``spindle/speed_cmd`` [rad/s] is valid in [0, max_spindle_speed]; ``spindle/current_cmd`` [A]
(torque mode) is valid when finite, and beyond +-current_limit it is saturated at the limit
by the motor (as a real drive does), and counted. A refused command leaves the last valid
one in force. No rclpy here: the node logs the refusals.
"""

from __future__ import annotations

import math

__all__ = ['SpindleCommands']


class SpindleCommands:
    """The last valid speed and current commands, and counts of those taken."""

    def __init__(self, speed: float):
        self.speed = speed
        self.current = 0.0
        self.counters = dict(commands_accepted=0, commands_refused=0, commands_saturated=0)

    def reset(self, speed: float) -> None:
        """Start again from ``speed`` [rad/s] and no current (the counts go on)."""
        self.speed = speed
        self.current = 0.0

    def of_mode(self, mode: str) -> float:
        """Return the command of spindle mode ``mode`` ('speed' or 'torque')."""
        return self.current if mode == 'torque' else self.speed

    def take_speed(self, value: float, limit: float) -> str:
        """Take a speed command [rad/s]; returns '' or why it is refused."""
        if not (math.isfinite(value) and 0.0 <= value <= limit):
            self.counters['commands_refused'] += 1
            return (f'refused spindle/speed_cmd {value!r}: valid range [0, {limit:g}] rad/s '
                    f'(max_spindle_speed); keeping {self.speed:g} rad/s')
        self.counters['commands_accepted'] += 1
        self.speed = value
        return ''

    def take_current(self, value: float, limit: float) -> str:
        """Take a current command [A] (``limit``: current_limit); returns '' or why not."""
        if not math.isfinite(value):
            self.counters['commands_refused'] += 1
            return (f'refused spindle/current_cmd {value!r}: a finite current in A is valid; '
                    f'keeping {self.current:g} A')
        self.counters['commands_accepted'] += 1
        if abs(value) > limit:
            self.counters['commands_saturated'] += 1
        self.current = value
        return ''

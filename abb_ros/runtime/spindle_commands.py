"""The spindle commands the simulator takes: the last valid ones, and what was refused.

``spindle/speed_cmd`` [rad/s] is valid in [0, max_spindle_speed]; ``spindle/current_cmd`` [A]
(torque mode) is valid when finite, and beyond +-current_limit it is saturated at the limit
by the motor (as a real drive does), and counted. A refused command leaves the last valid
one in force. No rclpy here: the node logs the refusals.

ros2_control's topic-based system sends its commands as one sensor_msgs/JointState
(:func:`joint_command` reads its fields): the ``spindle`` entry's ``velocity`` is a speed
command, its ``effort`` a torque command [N m], taken as the current torque / torque_constant
(:meth:`SpindleCommands.take_joint_command`), both with the checks above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

__all__ = ['SPINDLE_JOINT', 'JointCommand', 'SpindleCommands', 'joint_command']

SPINDLE_JOINT = 'spindle'
"""The one joint that takes commands (the balls are free)."""


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

    def refuse(self, why: str) -> str:
        """Count a command refused before its values were read; returns ``why``."""
        self.counters['commands_refused'] += 1
        return why

    def take_speed(self, value: float, limit: float, source: str = 'spindle/speed_cmd') -> str:
        """Take a speed command [rad/s] from ``source``; returns '' or why it is refused."""
        why = self._speed_refusal(value, limit, source)
        if why:
            return self.refuse(why)
        self.counters['commands_accepted'] += 1
        self.speed = value
        return ''

    def take_current(self, value: float, limit: float) -> str:
        """Take a current command [A] (``limit``: current_limit); returns '' or why not."""
        if not math.isfinite(value):
            return self.refuse(f'refused spindle/current_cmd {value!r}: a finite current in A '
                               f'is valid; keeping {self.current:g} A')
        self._take_current(value, limit)
        return ''

    def take_joint_command(self, command: 'JointCommand', speed_limit: float,
                           torque_constant: float, current_limit: float, source: str) -> str:
        """Take a ros2_control command from ``source``, all of it or none; '' or why not.

        ``command.velocity`` [rad/s] as :meth:`take_speed`; ``command.effort`` [N m] is the
        current effort / torque_constant [A], finite, saturated beyond current_limit as
        :meth:`take_current`. One message counts once, accepted or refused.
        """
        why = ''
        if command.velocity is not None:
            why = self._speed_refusal(command.velocity, speed_limit, f'{source} velocity')
        current = None
        if not why and command.effort is not None:
            current = command.effort / torque_constant if math.isfinite(command.effort) \
                else math.nan
            if not math.isfinite(current):
                why = (f'refused {source} effort {command.effort!r}: a finite torque in N m '
                       f'is valid; keeping {self.current * torque_constant:g} N m')
        if why:
            return self.refuse(why)
        if command.velocity is not None:
            self.speed = command.velocity
        if current is not None:
            self._take_current(current, current_limit)
        else:
            self.counters['commands_accepted'] += 1
        return ''

    def _take_current(self, value: float, limit: float) -> None:
        self.counters['commands_accepted'] += 1
        if abs(value) > limit:
            self.counters['commands_saturated'] += 1
        self.current = value

    def _speed_refusal(self, value: float, limit: float, source: str) -> str:
        if math.isfinite(value) and 0.0 <= value <= limit:
            return ''
        return (f'refused {source} {value!r}: valid range [0, {limit:g}] rad/s '
                f'(max_spindle_speed); keeping {self.speed:g} rad/s')


@dataclass(frozen=True)
class JointCommand:
    """The spindle's commands in one JointState: speed [rad/s], torque [N m] (None: absent)."""

    velocity: float | None = None
    effort: float | None = None


def joint_command(name: Sequence[str], position: Sequence[float], velocity: Sequence[float],
                  effort: Sequence[float]) -> tuple[JointCommand | None, str, str]:
    """Read the spindle's command from the fields of a sensor_msgs/JointState.

    Valid: ``name`` is exactly [``spindle``], ``velocity`` and/or ``effort`` hold one value
    each, ``position`` is empty (the spindle takes no position command). Returns
    (command, '', '') or (None, kind, why): ``kind`` one word for what was wrong
    ('empty', 'joints', 'lengths', 'position', 'no_command'), ``why`` one line.
    """
    names = list(name)
    sizes = dict(position=len(position), velocity=len(velocity), effort=len(effort))
    if not names:
        return None, 'empty', 'names no joint (an empty name array)'
    others = [n for n in names if n != SPINDLE_JOINT]
    if others:
        return None, 'joints', (f'names joint(s) {others}: only {SPINDLE_JOINT!r} takes '
                                'commands (declare only it in the <ros2_control> block)')
    if len(names) != 1:
        return None, 'joints', f'names {SPINDLE_JOINT!r} {len(names)} times'
    wrong = {field: size for field, size in sizes.items() if size not in (0, len(names))}
    if wrong:
        return None, 'lengths', (f'mismatched lengths: {len(names)} name(s) but ' + ', '.join(
            f'{size} {field} value(s)' for field, size in wrong.items()))
    if sizes['position']:
        return None, 'position', ('carries a position command: the spindle takes velocity '
                                  '(speed) or effort (torque) commands')
    if not (sizes['velocity'] or sizes['effort']):
        return None, 'no_command', 'carries no velocity or effort value'
    return JointCommand(velocity=float(velocity[0]) if sizes['velocity'] else None,
                        effort=float(effort[0]) if sizes['effort'] else None), '', ''

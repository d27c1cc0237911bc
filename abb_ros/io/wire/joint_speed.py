"""The spindle speed of a ``sensor_msgs/JointState``, read straight from its CDR bytes.

The analysis node needs few numbers of each ``joint_states`` message: omega, the velocity of
joint ``spindle`` (else the first velocity), and the ball angles phi_i (positions of the joints
``ball_*``, in name order). Deserialising the whole message into rclpy
objects at 1 kHz costs far more than the analysis itself; this reads the stamp, the joint
names and one double. The layout (XCDR1, little-endian; see :mod:`abb_ros.io.wire.cdr`) is parsed
once per distinct header + names and cached, so a message of the same layout costs one bytes
comparison and two ``unpack_from`` calls.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

__all__ = ['JointSpeed', 'JointSpeedReader']

_U32 = struct.Struct('<I')
_STAMP = struct.Struct('<iI')
_F64 = struct.Struct('<d')
_HEADER = 4   # encapsulation bytes; alignment counts from the byte after them


@dataclass(frozen=True)
class JointSpeed:
    """Spindle speed and ball angles read from a JointState.

    omega [rad/s] (nan when the message has no velocity), the ball count (joints named
    ``ball_*``), whether any name was given, the header stamp [ns] and the ball angles phi
    [rad] (empty when the message has no position for every ball).
    """

    omega: float
    n: int
    named: bool
    stamp_ns: int
    phi: tuple = ()


class JointSpeedReader:
    """Callable on the CDR bytes of a JointState; raises ValueError on malformed bytes."""

    def __init__(self):
        self._key = None      # bytes from frame_id to the end of the names
        self._layout = None   # (omega offset or None, n, named)

    def __call__(self, data: bytes) -> JointSpeed:
        """Read the :class:`JointSpeed` of the CDR bytes ``data``."""
        if len(data) < _HEADER + 12:
            raise ValueError(f'JointState of {len(data)} bytes is too short')
        sec, nanosec = _STAMP.unpack_from(data, _HEADER)
        start = _HEADER + 8
        names_end = self._names_end(data, start)
        key = data[start:names_end]
        if key != self._key:
            self._layout = self._parse(data, names_end)
            self._key = key
        offset, n, named, positions = self._layout
        omega = _F64.unpack_from(data, offset)[0] if offset is not None else math.nan
        phi = ()
        if positions is not None:
            values = positions[0].unpack_from(data, positions[1])
            phi = tuple(values[i] for i in positions[2])
        return JointSpeed(omega, n, named, sec * 1_000_000_000 + nanosec, phi)

    def _names_end(self, data: bytes, pos: int) -> int:
        """Return the byte after the frame_id and the name sequence (a cheap walk over lengths)."""
        if self._key is not None and data.startswith(self._key, pos):
            return pos + len(self._key)
        pos = _string_end(data, pos)
        count, pos = _u32(data, pos)
        for _ in range(count):
            pos = _string_end(data, pos)
        return pos

    @staticmethod
    def _parse(data: bytes, names_end: int):
        pos = _HEADER + 8
        pos = _string_end(data, pos)
        count, pos = _u32(data, pos)
        names = []
        for _ in range(count):
            length, pos = _u32(data, pos)
            names.append(data[pos:pos + length - 1].decode('utf-8', 'replace'))
            pos += length
        positions, pos = _u32(data, names_end)
        balls = [i for i, name in enumerate(names) if name.startswith('ball_')]
        ball_positions = None
        if positions:
            pos = _align(pos, 8)
            if pos + 8 * positions > len(data):
                raise ValueError('JointState position sequence runs past the message')
            if balls and balls[-1] < positions:
                ball_positions = (struct.Struct(f'<{positions}d'), pos, balls)
            pos += 8 * positions
        velocities, pos = _u32(data, pos)
        pos = _align(pos, 8)
        if velocities and pos + 8 * velocities > len(data):
            raise ValueError('JointState velocity sequence runs past the message')
        index = names.index('spindle') if 'spindle' in names else 0
        offset = pos + 8 * index if index < velocities else None
        return offset, len(balls), bool(names), ball_positions


def _align(pos: int, size: int) -> int:
    return pos + (-(pos - _HEADER) % size)


def _u32(data: bytes, pos: int) -> tuple[int, int]:
    pos = _align(pos, 4)
    if pos + 4 > len(data):
        raise ValueError('JointState ends inside a sequence length')
    return _U32.unpack_from(data, pos)[0], pos + 4


def _string_end(data: bytes, pos: int) -> int:
    length, pos = _u32(data, pos)
    if pos + length > len(data):
        raise ValueError('JointState string runs past the message')
    return pos + length

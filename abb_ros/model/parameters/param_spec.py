"""The parameter spec: one declaration per parameter, one check, one error.

A :class:`ParamSpec` holds a parameter's ROS name, default, unit, type, range (open or closed
ends), description, whether it is read-only and when a change applies; it names none of
its consumers (data flows one way: the nodes and the command line say which parameters they
take). :meth:`ParamSpec.check` is the one validation; an invalid value raises
:class:`ParamError`, one line naming the parameter and what is valid.

The lists live beside what they configure: the drive's in
:mod:`abb_ros.model.parameters.drive_spec`, the plant's (step and publish rates, spindle, IMU,
motor) in :mod:`abb_ros.model.parameters.plant_spec`, each node's own in
``abb_ros/nodes/<node>_params.py``; :mod:`abb_ros.nodes.ros.parameter_table` collects them all
(descriptors, docs/parameters.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

__all__ = ['ParamError', 'ParamSpec', 'DRIVE_PREFIX', 'DOUBLE', 'INTEGER', 'BOOL',
           'STRING', 'DOUBLE_ARRAY', 'STRING_ARRAY']

DRIVE_PREFIX = 'drive.'
"""ROS prefix of the drive's parameters (``drive.k``; ``--set`` and DriveParams say ``k``)."""

DOUBLE, INTEGER, BOOL, STRING = 'double', 'integer', 'bool', 'string'
DOUBLE_ARRAY, STRING_ARRAY = 'double_array', 'string_array'


class ParamError(ValueError):
    """A parameter value outside its valid range (or of the wrong type).

    Attributes ``name`` (the parameter), ``value``, ``valid`` (the range, as text) and
    ``why``.
    """

    def __init__(self, name: str, value: Any, valid: str, why: str = ''):
        self.name = name
        self.value = value
        self.valid = valid
        self.why = why
        msg = f'parameter {name!r} = {value!r} is invalid: valid range is {valid}'
        if why:
            msg += f' ({why})'
        super().__init__(msg)

    def renamed(self, name: str) -> 'ParamError':
        """Return the same error naming ``name`` (the ROS name drive.k of the SI name k)."""
        return ParamError(name, self.value, self.valid, self.why)


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@dataclass(frozen=True)
class ParamSpec:
    """One parameter, declared once.

    ``name`` is the ROS name (``drive.k``, ``imu.rate_hz``); ``low``/``high`` bound numbers
    and each element of a ``double_array`` (None: unbounded), ``*_open`` makes a bound
    exclusive; ``default`` None is computed when declared (documented in ``description``).
    """

    name: str
    default: Any
    unit: str
    description: str
    type: str = DOUBLE
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    read_only: bool = False
    applies: str = ''
    length: int | None = None
    choices: tuple = ()

    @property
    def short(self) -> str:
        """Return the name without ``drive.``: the SI name of DriveParams and ``--set``."""
        return self.name[len(DRIVE_PREFIX):] if self.name.startswith(DRIVE_PREFIX) else self.name

    def valid_text(self) -> str:
        """Return what is valid, e.g. ``(0, inf) N/m``."""
        if self.type in (DOUBLE, INTEGER):
            return f'{self._interval()} {self.unit}'.rstrip()
        if self.type == BOOL:
            return 'true or false'
        if self.type == STRING:
            return 'one of ' + ', '.join(self.choices) if self.choices else 'a string'
        if self.type == DOUBLE_ARRAY:
            if self.low is None and self.high is None:
                return f'{self.length} finite values [{self.unit}]'
            return f'{self.length} values in {self._interval()} [{self.unit}]'
        return 'a list of strings'

    def _interval(self) -> str:
        low = -math.inf if self.low is None else self.low
        high = math.inf if self.high is None else self.high
        fmt = (lambda x: str(int(x))) if self.type == INTEGER else (lambda x: f'{x:g}')
        lo = '(-inf' if math.isinf(low) else ('(' if self.low_open else '[') + fmt(low)
        hi = 'inf)' if math.isinf(high) else fmt(high) + (')' if self.high_open else ']')
        return f'{lo}, {hi}'

    def check(self, value: Any, name: str | None = None, strict: bool = False) -> Any:
        """Return ``value`` if valid (an int for a double becomes a float).

        Raises ParamError naming ``name`` (default: this spec's name). ``strict``: a float for
        an integer is refused even when whole (ROS types), otherwise 2.0 is accepted as 2.
        """
        name = name or self.name
        if self.type == DOUBLE:
            value = self._number(name, value)
            return float(value) if isinstance(value, int) else value
        if self.type == INTEGER:
            return self._integer(name, value, strict)
        if self.type == BOOL:
            if not isinstance(value, bool):
                raise ParamError(name, value, self.valid_text(), 'not true or false')
            return value
        if self.type == STRING:
            if not isinstance(value, str) or (self.choices and value not in self.choices):
                raise ParamError(name, value, self.valid_text())
            return value
        value = _plain(value)
        if self.type == DOUBLE_ARRAY:
            ok = isinstance(value, list) and len(value) == self.length and all(
                _is_number(x) and math.isfinite(x) and self._within(x) for x in value)
            if not ok:
                raise ParamError(name, value, self.valid_text())
            return [float(x) for x in value]
        if not (isinstance(value, list) and all(isinstance(x, str) for x in value)):
            raise ParamError(name, value, self.valid_text())
        return value

    def _integer(self, name, value, strict: bool):
        """Return ``value`` as an integer in range (a whole float too unless ``strict``)."""
        if isinstance(value, float) and not strict and value.is_integer():
            value = int(value)
        if isinstance(value, float):
            raise ParamError(name, value, self.valid_text(), 'not an integer')
        return self._number(name, value)

    def _number(self, name, value):
        if not _is_number(value):
            raise ParamError(name, _plain(value), self.valid_text(), 'not a number')
        if not math.isfinite(value):
            raise ParamError(name, value, self.valid_text(), 'not finite')
        if not self._within(value):
            raise ParamError(name, value, self.valid_text())
        return value

    def _within(self, value) -> bool:
        low, high = self.low, self.high
        return not ((low is not None and (value < low or (self.low_open and value == low)))
                    or (high is not None and (value > high or (self.high_open
                                                               and value == high))))


def _plain(value):
    """Return a list for a sequence (rclpy gives array.array for arrays), else the value."""
    if isinstance(value, (str, bytes, dict)) or not hasattr(value, '__len__'):
        return value
    return list(value)

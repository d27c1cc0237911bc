"""Checks of the fields of a YAML document: each returns the value or raises one line.

Every file format the package reads from YAML (scenarios, sweep specs) checks its fields
here, so a wrong field reads the same everywhere: a :class:`ParamError` naming the field by
its dotted path (``scenario.spindle.tau``, ``compute.run.dt``), the value, and what is valid.
"""

from __future__ import annotations

import math

from abb_ros.model.parameters.param_spec import ParamError

__all__ = ['short', 'finite_number', 'mapping', 'text']


def short(value):
    """Return ``value`` for an error message: numbers as they are, other reprs cut to a line."""
    if isinstance(value, (int, float)) or value is None:
        return value
    shown = repr(value)
    return shown if len(shown) <= 60 else shown[:57] + '...'


def _field(where: str, key) -> str:
    """Return the dotted path of ``key`` under ``where`` (the key alone at the top)."""
    return f'{where}.{key}' if where else str(key)


def finite_number(where, value, low=-math.inf, low_open=False, high=math.inf, unit=''):
    """Return ``value`` as a float when it is a finite number in the range; else ParamError.

    Returns
    -------
    float
        The number.
    """
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if ok:
        ok = (value > low if low_open else value >= low) and value <= high
    if not ok:
        lo = f'({low:g}' if low_open else f'[{low:g}'
        hi = 'inf)' if math.isinf(high) else f'{high:g}]'
        raise ParamError(where, short(value), f'a finite number in {lo}, {hi} {unit}'.rstrip())
    return float(value)


def mapping(where, value, keys, required=()) -> dict:
    """Return ``value`` when it is a mapping of text keys among ``keys`` holding ``required``.

    Returns
    -------
    dict
        ``value`` itself.
    """
    valid = 'a mapping with keys ' + ', '.join(sorted(keys))
    if not isinstance(value, dict):
        raise ParamError(where, short(value), valid)
    for key in value:
        if not isinstance(key, str):
            raise ParamError(f'{where} key {key!r}', short(value[key]), valid,
                             'keys must be text')
        if key not in keys:
            raise ParamError(_field(where, key), short(value[key]), valid, 'unknown key')
    for key in required:
        if key not in value:
            raise ParamError(_field(where, key), None, 'required', 'missing')
    return value


def text(where, value) -> str:
    """Return ``value`` when it is text; else ParamError.

    Returns
    -------
    str
        The text.
    """
    if not isinstance(value, str):
        raise ParamError(where, short(value), 'text')
    return value

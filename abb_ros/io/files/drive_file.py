"""The drive's parameters in a ROS 2 parameter file: read and write.

The file has the form ``<node or /**>: ros__parameters: drive: {a: ..., ...}`` (SI names,
as config/cdrom_table1.yaml); ``abb-sim --config`` and the nodes' ``--params-file`` take it.
Reading goes through :mod:`abb_ros.io.files.safe_yaml`; any problem is a :class:`ParamError`.
"""

from __future__ import annotations

from typing import Mapping

import yaml

from abb_ros.io.files.safe_yaml import YamlFileError, load_file
from abb_ros.model.parameters.params import DriveParams, ParamError

__all__ = ['read_drive_yaml', 'write_drive_yaml']


def read_drive_yaml(path, node: str | None = None) -> DriveParams:
    """Return the ``drive.*`` parameters of the ROS 2 parameter file ``path``.

    With ``node`` given, that node's section is used (falling back to ``/**``); otherwise
    the first section that has ``drive``. Raises ParamError naming ``config`` (the file
    cannot be read), ``drive`` (no drive section) or the parameter.
    """
    try:
        doc = load_file(path) or {}
    except YamlFileError as exc:
        raise ParamError('config', str(path), 'a ROS 2 parameter file', exc.why) from None
    if not isinstance(doc, Mapping):
        raise ParamError('config', str(path), 'a mapping <node>: ros__parameters: drive:',
                         f'the document is a {type(doc).__name__}')
    section = _find_drive_section(doc, node)
    if section is None:
        raise ParamError('drive', None, 'a mapping under <node>: ros__parameters: drive:',
                         f'no drive parameters in {path}')
    return DriveParams.from_mapping(_flat(section))


def _flat(section: Mapping, prefix: str = '') -> dict:
    """Return the drive section with nested groups as dotted names (race2: {n: 2} = race2.n)."""
    out = {}
    for key, value in section.items():
        name = f'{prefix}{key}'
        if isinstance(value, Mapping):
            out.update(_flat(value, name + '.'))
        else:
            out[name] = value
    return out


def _nested(values: Mapping) -> dict:
    """Return {name: value} with dotted names as nested groups, as ROS 2 writes them."""
    out = {}
    for name, value in values.items():
        *groups, leaf = name.split('.')
        place = out
        for group in groups:
            place = place.setdefault(group, {})
        place[leaf] = value
    return out


def write_drive_yaml(params: DriveParams, path, node: str = '/**') -> None:
    """Write ``params`` to ``path`` as a ROS 2 parameter file (``drive.*`` names)."""
    doc = {node: {'ros__parameters': {'drive': _nested(params.as_dict())}}}
    with open(path, 'w', encoding='utf-8') as f:
        f.write('# abb_ros drive parameters, SI units (see abb_ros/model/parameters/params.py)\n')
        yaml.safe_dump(doc, f, sort_keys=False)


def _find_drive_section(doc: Mapping, node: str | None):
    candidates = []
    if node is not None:
        candidates += [node, '/' + node.lstrip('/')]
    candidates += ['/**']
    sections = [doc.get(key) for key in candidates]
    if node is None:
        sections += list(doc.values())
    for sec in sections:
        ros = sec.get('ros__parameters') if isinstance(sec, Mapping) else None
        drive = ros.get('drive') if isinstance(ros, Mapping) else None
        if isinstance(drive, Mapping):
            return drive
    return None

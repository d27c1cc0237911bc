r"""ROS 2 message definitions as rosbag2 stores them in an MCAP schema, and type hashes.

rosbag2 (``rosbag2_cpp::LocalMessageDefinitionSource``, Jazzy) builds the ``ros2msg`` schema
text from the installed ``.msg`` files: the top-level text, then for every dependency not seen
yet, depth-first in sorted order, ``"\n" + "=" * 80 + "\nMSG: pkg/Name\n"`` and its text.
The same procedure is followed here, on the ``share/<pkg>/msg/*.msg`` files of the message
packages installed beside rclpy. The type description hash (``RIHS01_...``) is read from the
``.json`` type description that rosidl installs beside each ``.msg`` file.
"""

from __future__ import annotations

import functools
import importlib
import json
import os
import re
import sys
from pathlib import Path

DELIMITER = '=' * 80 + '\n'
PRIMITIVE_TYPES = frozenset((
    'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16',
    'int32', 'uint32', 'int64', 'uint64', 'string'))
# rosbag2's MSG_FIELD_TYPE_REGEX: the type token at the start of a line ("pkg/Name[] field").
_FIELD_TYPE = re.compile(r'(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+')
_NAME = r'[a-zA-Z][a-zA-Z0-9_]*'
_TYPE_NAME = re.compile(rf'^({_NAME})/(?:(msg)/)?({_NAME})$')
MAX_DEPTH = 50


class MessageTypeError(ValueError):
    """A message type name that is malformed or whose package is not installed."""


def split_type(type_name: str) -> tuple[str, str]:
    """Split ``'sensor_msgs/msg/JointState'`` or ``'sensor_msgs/JointState'`` into (pkg, name)."""
    match = _TYPE_NAME.match(type_name or '')
    if not match:
        raise MessageTypeError(
            f'message type {type_name!r} is not of the form pkg/msg/Name')
    return match.group(1), match.group(3)


def normalize_type(type_name: str) -> str:
    """Return the full ROS 2 type name, ``pkg/msg/Name``."""
    package, name = split_type(type_name)
    return f'{package}/msg/{name}'


def share_dir(package: str) -> Path:
    """Return ``share/<package>`` of an installed ROS package (ament index, then this prefix)."""
    prefixes = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    prefixes.append(sys.prefix)
    for prefix in prefixes:
        path = Path(prefix) / 'share' / package
        if path.is_dir():
            return path
    raise MessageTypeError(f'ROS package {package!r} is not installed (no share/{package})')


@functools.lru_cache(maxsize=None)
def _msg_text(package: str, name: str) -> str:
    path = share_dir(package) / 'msg' / f'{name}.msg'
    try:
        return path.read_text(encoding='utf-8')
    except FileNotFoundError:
        raise MessageTypeError(f'no message definition {path}') from None


def _dependencies(text: str, package: str) -> list[str]:
    found = set()
    for match in _FIELD_TYPE.finditer(text):
        token = match.group(1)
        if token in PRIMITIVE_TYPES:
            continue
        found.add(token if '/' in token else f'{package}/{token}')
    return sorted(found)


@functools.lru_cache(maxsize=None)
def full_text(type_name: str) -> str:
    """Return the ``ros2msg`` schema text of ``type_name`` with its dependencies, as rosbag2."""
    root = split_type(type_name)
    seen: set[str] = set()

    def append(package: str, name: str, depth: int) -> str:
        if depth <= 0:
            raise MessageTypeError(f'recursion too deep resolving {type_name}')
        text = _msg_text(package, name)
        for dep in _dependencies(text, package):
            if dep not in seen:
                seen.add(dep)
                text += '\n' + DELIMITER + f'MSG: {dep}\n' + append(*split_type(dep), depth - 1)
        return text

    return append(*root, MAX_DEPTH)


@functools.lru_cache(maxsize=None)
def type_hash(type_name: str) -> str:
    """Return the RIHS01 type description hash of ``type_name``, '' when none is installed."""
    package, name = split_type(type_name)
    full = f'{package}/msg/{name}'
    try:
        doc = json.loads((share_dir(package) / 'msg' / f'{name}.json').read_text())
    except (OSError, ValueError, MessageTypeError):
        return ''
    for entry in doc.get('type_hashes', []):
        if entry.get('type_name') == full:
            return entry.get('hash_string', '')
    return ''


@functools.lru_cache(maxsize=None)
def message_class(type_name: str):
    """Return the rclpy (rosidl Python) message class of ``type_name``."""
    package, name = split_type(type_name)
    try:
        module = importlib.import_module(f'{package}.msg')
        return getattr(module, name)
    except (ImportError, AttributeError):
        raise MessageTypeError(
            f'message type {type_name!r} is not installed for Python') from None


def type_name_of(msg) -> str:
    """Return ``'pkg/msg/Name'`` of an rclpy message instance."""
    cls = type(msg)
    package = cls.__module__.split('.')[0]
    return f'{package}/msg/{cls.__name__}'

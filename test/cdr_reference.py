"""Reference CDR encoder for the tests: rclpy message -> the bytes a Fast DDS publisher sends.

Built on rosbags' CDR serialiser (exact length, zero padding), independent of the package's
own encoder :mod:`abb_ros.io.wire.cdr`, which the tests check against it; test_bag checks this one
against what a raw subscription receives over DDS. rosbags is a test-only dependency.
"""

from __future__ import annotations

import functools

from abb_ros.io.wire import msgdefs


@functools.lru_cache(maxsize=1)
def _typestore():
    from rosbags.typesys import Stores, get_typestore
    return get_typestore(Stores.ROS2_JAZZY)


_DTYPES = {'bool': 'bool', 'byte': 'uint8', 'octet': 'uint8', 'char': 'uint8', 'uint8': 'uint8',
           'int8': 'int8', 'int16': 'int16', 'uint16': 'uint16', 'int32': 'int32',
           'uint32': 'uint32', 'int64': 'int64', 'uint64': 'uint64', 'float32': 'float32',
           'float64': 'float64'}


def _scalar(value):
    return value[0] if isinstance(value, bytes) else value


def _field_converter(desc):
    import numpy as np
    from rosbags.interfaces import Nodetype
    kind, detail = desc
    if kind == Nodetype.NAME:
        return _converter(detail)
    if kind == Nodetype.BASE:
        return (lambda v: v) if detail[0] == 'string' else _scalar
    (sub_kind, sub_detail), _ = detail
    if sub_kind == Nodetype.BASE and sub_detail[0] != 'string':
        dtype = np.dtype(_DTYPES[sub_detail[0]])
        if dtype == np.uint8:
            return _uint8_array
        return lambda v: np.asarray(v, dtype=dtype)
    element = _field_converter((sub_kind, sub_detail))
    return lambda v: [element(x) for x in v]


def _uint8_array(value):
    import numpy as np
    if isinstance(value, (bytes, bytearray)):
        return np.frombuffer(bytes(value), dtype=np.uint8)
    return np.asarray([_scalar(x) for x in value], dtype=np.uint8)


@functools.lru_cache(maxsize=None)
def _converter(type_name: str):
    """rclpy message -> rosbags message object of the same type, field by field."""
    store = _typestore()
    msgdef = store.get_msgdef(type_name)
    fields = [(name, _field_converter(desc)) for name, desc in msgdef.fields]
    cls = msgdef.cls

    def convert(msg):
        return cls(**{name: conv(getattr(msg, name)) for name, conv in fields})
    return convert


def cdr_bytes(message) -> bytes:
    """The CDR bytes of an rclpy message, as a Fast DDS publisher puts them on the wire.

    ``rclpy.serialization.serialize_message`` sizes its buffer by Fast CDR's estimate, so its
    output can end in stray bytes and leaves padding uninitialised (not reproducible). The
    message is serialised instead with rosbags' CDR (exact length, zero padding), which gives
    the bytes that a raw subscription receives (test_bag checks this over DDS).
    """
    type_name = msgdefs.type_name_of(message)
    obj = _converter(type_name)(message)
    return bytes(_typestore().serialize_cdr(obj, type_name, little_endian=True))

"""YAML read with limits: every YAML file abb_ros reads goes through here.

A parameter file, a scenario or a bag's ``metadata.yaml`` is read with a size cap, a nesting
cap, no aliases (``*name``) and no key twice in one mapping (YAML would keep the last one
silently): a 1 KB "billion laughs" file of nested aliases would otherwise expand
to gigabytes when it is printed or walked, and a file of ten thousand ``[`` would exhaust the
parser's recursion. Any problem (missing file, a directory, not UTF-8, malformed, over a limit)
is one :class:`YamlFileError` that names the file and what is wrong.

Numbers are read as ROS parameter files and YAML 1.2 read them: ``5e-5`` and ``1E3`` are floats
(YAML 1.1, PyYAML's default, wants a dot in the mantissa and a sign in the exponent and reads
them as text), so a value means the same in a parameter file, a scenario, a sweep spec and on
the command line. A sequence tagged ``!!python/tuple`` is read as a list, as rcl reads it:
``ros2 launch`` (launch_ros) writes a node's list parameters into its temporary parameter file
with that tag.
"""

from __future__ import annotations

import re
from pathlib import Path

import yaml

__all__ = ['YamlFileError', 'load_file', 'load_text', 'MAX_BYTES', 'MAX_DEPTH', 'FLOAT_12']

MAX_BYTES = 64 * 1024
"""Largest YAML file read [bytes]: parameter files and scenarios are a few KB; 64 KB parses in
under a second with libyaml on a loaded 2-core machine (pure-Python PyYAML: 5 to 10 times
longer)."""
MAX_DEPTH = 32
"""Deepest nesting of mappings and sequences accepted (ROS 2 parameter files use about 5)."""


class YamlFileError(ValueError):
    """A YAML file that cannot be read: ``path`` and ``why`` (one line)."""

    def __init__(self, path, why: str):
        self.path = str(path)
        self.why = why
        super().__init__(f'{self.path}: {why}')


class _PyLoader(yaml.SafeLoader):
    """SafeLoader that stops scanning flow collections nested deeper than ``MAX_DEPTH``.

    Its bookkeeping is quadratic in the flow depth; used where PyYAML has no libyaml.
    """

    def fetch_flow_collection_start(self, TokenClass):
        if self.flow_level >= MAX_DEPTH:
            raise yaml.YAMLError(f'nested deeper than {MAX_DEPTH} levels '
                                 f'(line {self.line + 1})')
        super().fetch_flow_collection_start(TokenClass)


FLOAT_12 = re.compile(r'^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?$')
"""A float of the YAML 1.2 core schema (the rule rcl's parameter-file parser follows too):
mantissa with or without a dot, exponent with or without a sign. Whole numbers without an
exponent are matched first by the integer rule, so ``5`` stays an int."""


PYTHON_TUPLE = 'tag:yaml.org,2002:python/tuple'
"""The tag PyYAML's ``yaml.dump`` gives a tuple (launch_ros's list parameters)."""


def _ros_loader(base):
    """Return a subclass of the loader ``base`` that reads as ROS parameter files are read.

    YAML 1.2 floats are floats: the resolver is appended after PyYAML's own, whose float
    (with a dot) and int rules come first, so only what they leave as text (``5e-5``,
    ``1E3``, ``1.e+3``) is added. A ``!!python/tuple`` sequence is a list (only that tag:
    no other Python object is constructed).
    """
    loader = type(f'{base.__name__}12', (base,), {})
    loader.add_implicit_resolver('tag:yaml.org,2002:float', FLOAT_12, list('-+.0123456789'))
    loader.add_constructor(PYTHON_TUPLE, lambda self, node: self.construct_sequence(node))
    return loader


_LOADER = _ros_loader(getattr(yaml, 'CSafeLoader', None) or _PyLoader)


def _one_line(exc: yaml.YAMLError) -> str:
    mark = getattr(exc, 'problem_mark', None)
    problem = getattr(exc, 'problem', None)
    if problem and mark is not None:
        return f'malformed YAML: {problem} (line {mark.line + 1}, column {mark.column + 1})'
    return ' '.join(str(exc).split())


def _key_path(open_: list) -> str:
    """Return the dotted path of mapping keys down to the innermost open collection.

    Its middle is elided past four keys; '' when no mapping is open.
    """
    keys = [str(c[2]) for c in open_[:-1] if c is not None and c[2] is not None]
    if len(keys) > 4:
        return '.'.join(keys[:2]) + ' ... ' + '.'.join(keys[-2:])
    return '.'.join(keys)


def _check_events(text: str) -> None:
    """Refuse aliases, deep nesting and repeated keys from the event stream, before building."""
    open_ = []     # per open collection: [keys seen, next node is a key, last key] or None
    for event in yaml.parse(text, Loader=_LOADER):
        if isinstance(event, yaml.AliasEvent):
            raise yaml.YAMLError(f'YAML aliases (*name) are not accepted '
                                 f'(line {event.start_mark.line + 1})')
        if isinstance(event, (yaml.ScalarEvent, yaml.CollectionStartEvent)) and open_ \
                and open_[-1] is not None:
            keys, is_key, _ = open_[-1]
            if is_key and isinstance(event, yaml.ScalarEvent):
                if event.value in keys:
                    raise yaml.YAMLError(f'the key {event.value!r} appears twice in one '
                                         f'mapping (line {event.start_mark.line + 1})')
                keys.add(event.value)
                open_[-1][2] = event.value
            open_[-1][1] = not is_key
        if isinstance(event, yaml.CollectionStartEvent):
            open_.append([set(), True, None] if isinstance(event, yaml.MappingStartEvent)
                         else None)
            if len(open_) > MAX_DEPTH:
                path = _key_path(open_)
                under = f' under the key {path!r}' if path else ''
                raise yaml.YAMLError(f'nested deeper than {MAX_DEPTH} levels{under} '
                                     f'(line {event.start_mark.line + 1})')
        elif isinstance(event, yaml.CollectionEndEvent):
            open_.pop()


def load_text(text: str, where='<text>', max_bytes: int = MAX_BYTES):
    """Return the YAML document in ``text``; :class:`YamlFileError` naming ``where`` if none."""
    if len(text) > max_bytes:
        raise YamlFileError(where, f'larger than {max_bytes} bytes')
    try:
        _check_events(text)
        return yaml.load(text, Loader=_LOADER)  # noqa: S506 - a SafeLoader, aliases refused
    except yaml.YAMLError as exc:
        raise YamlFileError(where, _one_line(exc)) from None


def load_file(path, max_bytes: int = MAX_BYTES):
    """Return the YAML document in the file ``path`` (None for an empty file)."""
    path = Path(path)
    try:
        with open(path, 'rb') as f:
            data = f.read(max_bytes + 1)
    except FileNotFoundError:
        raise YamlFileError(path, 'no such file') from None
    except IsADirectoryError:
        raise YamlFileError(path, 'is a directory, not a YAML file') from None
    except OSError as exc:
        raise YamlFileError(path, f'cannot be read ({exc.strerror or exc})') from None
    if len(data) > max_bytes:
        raise YamlFileError(path, f'larger than {max_bytes} bytes')
    try:
        text = data.decode('utf-8')
    except UnicodeDecodeError as exc:
        raise YamlFileError(path, f'not UTF-8 text (byte {exc.start})') from None
    return load_text(text, path, max_bytes)

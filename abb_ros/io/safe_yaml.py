"""YAML read with limits: every YAML file abb_ros reads goes through here.

A parameter file, a scenario or a bag's ``metadata.yaml`` is read with a size cap, a nesting cap
and no aliases (``*name``): a 1 KB "billion laughs" file of nested aliases would otherwise expand
to gigabytes when it is printed or walked, and a file of ten thousand ``[`` would exhaust the
parser's recursion. Any problem (missing file, a directory, not UTF-8, malformed, over a limit)
is one :class:`YamlFileError` that names the file and what is wrong.
"""

from __future__ import annotations

from pathlib import Path

import yaml

__all__ = ['YamlFileError', 'load_file', 'load_text', 'MAX_BYTES', 'MAX_DEPTH']

MAX_BYTES = 1 << 20
"""Largest YAML file read [bytes]; parameter files and scenarios are a few KB."""
MAX_DEPTH = 32
"""Deepest nesting of mappings and sequences accepted (ROS 2 parameter files use about 5)."""


class YamlFileError(ValueError):
    """A YAML file that cannot be read: ``path`` and ``why`` (one line)."""

    def __init__(self, path, why: str):
        self.path = str(path)
        self.why = why
        super().__init__(f'{self.path}: {why}')


class _LimitedLoader(yaml.SafeLoader):
    """SafeLoader that refuses aliases and nesting deeper than ``MAX_DEPTH``."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0

    def fetch_flow_collection_start(self, TokenClass):
        # the scanner's bookkeeping is quadratic in the flow depth: stop before it matters
        if self.flow_level >= MAX_DEPTH:
            raise yaml.YAMLError(f'nested deeper than {MAX_DEPTH} levels '
                                 f'(line {self.line + 1})')
        super().fetch_flow_collection_start(TokenClass)

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            mark = self.peek_event().start_mark
            raise yaml.YAMLError(f'YAML aliases (*name) are not accepted (line {mark.line + 1})')
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                mark = self.peek_event().start_mark
                raise yaml.YAMLError(f'nested deeper than {MAX_DEPTH} levels '
                                     f'(line {mark.line + 1})')
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def _one_line(exc: yaml.YAMLError) -> str:
    mark = getattr(exc, 'problem_mark', None)
    problem = getattr(exc, 'problem', None)
    if problem and mark is not None:
        return f'malformed YAML: {problem} (line {mark.line + 1}, column {mark.column + 1})'
    return ' '.join(str(exc).split())


def load_text(text: str, where='<text>', max_bytes: int = MAX_BYTES):
    """The YAML document in ``text``; :class:`YamlFileError` naming ``where`` if it is not one."""
    if len(text) > max_bytes:
        raise YamlFileError(where, f'larger than {max_bytes} bytes')
    try:
        return yaml.load(text, Loader=_LimitedLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        raise YamlFileError(where, _one_line(exc)) from None


def load_file(path, max_bytes: int = MAX_BYTES):
    """The YAML document in the file ``path`` (None for an empty file)."""
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

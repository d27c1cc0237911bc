"""The nodes' start-up parameter files and ``-p`` overrides, checked before the node starts.

rclpy hands a node only the values of parameters it declares: a key it does not declare
(``drive.kk``, ``pubish_rate_hz``), a section whose node name matches no node, or a file of
one line of text are dropped without a word, and the node runs on defaults. This module reads
the ROS arguments the node was started with as rcl reads them (the ``--ros-args`` ...
``--`` ranges; ``--params-file FILE``, ``-p [node:]name:=value``, ``-r [node:]__node:=`` and
``__ns:=``), reads each file with :mod:`abb_ros.io.files.safe_yaml` (no key twice, no aliases) and
raises :class:`ParamFileError`, one line naming the file and the key, for:

- a document that is not a mapping of node names to ``ros__parameters`` (text, a list, a
  node name whose value is not a mapping, nothing under ``ros__parameters``);
- a file with no section for this node (a misspelt node name);
- a parameter this node does not take, in a section naming this node, or that no abb_ros node
  takes, in a wildcard section (``/**``: one file may serve several nodes);
- a parameter given twice in one section (``drive.k`` and ``drive: {k: ...}``).

No rclpy here: :func:`abb_ros.nodes.ros.entry_point.run_node` calls :func:`check_arguments` after
``rclpy.init`` has accepted the arguments and before the node is made.
"""

from __future__ import annotations

import re
from typing import Iterable, Mapping

from abb_ros.io.files.safe_yaml import YamlFileError, load_file

__all__ = ['ParamFileError', 'RosArguments', 'parse_ros_arguments', 'node_name_matches',
           'check_file', 'check_arguments', 'ROS_BUILTIN']

ROS_BUILTIN = frozenset({'use_sim_time', 'start_type_description_service'})
"""Parameters rclpy declares on every node (Jazzy)."""
PARAMS_KEY = 'ros__parameters'
_WITH_VALUE = frozenset({'-p', '--param', '-r', '--remap', '--params-file', '--log-level',
                         '--log-file-name', '--log-config-file', '-e', '--enclave'})
"""rcl's ROS flags that take the next argument (the others, --enable-*/--disable-*, not)."""


class ParamFileError(ValueError):
    """A parameter file or override the node would silently ignore; one line."""


class RosArguments:
    """What the ROS arguments say about parameters and this node's name.

    ``files`` (``--params-file``), ``overrides`` ([node or None, name] of each ``-p``),
    ``remaps`` ([node or None, from, to] of each ``-r``).
    """

    def __init__(self):
        self.files: list[str] = []
        self.overrides: list[tuple[str | None, str]] = []
        self.remaps: list[tuple[str | None, str, str]] = []

    def node_name(self, name: str, namespace: str = '/') -> str:
        """Return the fully qualified name of node ``name`` after the ``__node``/``__ns`` remaps.

        As rcl applies them: the first rule that applies wins (global or aimed at ``name``).
        """
        new_name = new_ns = None
        for node, src, dst in self.remaps:
            if node not in (None, name):
                continue
            if src == '__node' and new_name is None:
                new_name = dst
            elif src == '__ns' and new_ns is None:
                new_ns = dst
        ns = (new_ns or namespace).strip('/')
        return f'/{ns}/{new_name or name}' if ns else f'/{new_name or name}'


def _split_target(rule: str) -> tuple[str | None, str]:
    """Split ``node:rest`` (a rule aimed at one node) from ``rest``; ``:=`` is not a target."""
    head, sep, rest = rule.partition(':')
    if sep and not rest.startswith('='):
        return head, rest
    return None, rule


def parse_ros_arguments(argv: Iterable[str]) -> RosArguments:
    """Return the parameter-related ROS arguments of ``argv`` (as rcl parses them).

    ROS arguments are those after ``--ros-args`` up to ``--`` or the next ``--ros-args``.
    Malformed rules are rcl's to refuse (it does, before this is called).
    """
    out = RosArguments()
    args = list(argv)
    inside = False
    i = 0
    while i < len(args):
        arg = args[i]
        if arg == '--ros-args':
            inside = True
        elif inside and arg == '--':
            inside = False
        elif inside and arg in _WITH_VALUE and i + 1 < len(args):
            value = args[i + 1]
            i += 1
            if arg == '--params-file':
                out.files.append(value)
            elif arg in ('-p', '--param'):
                node, rule = _split_target(value)
                out.overrides.append((node, rule.split(':=', 1)[0]))
            elif arg in ('-r', '--remap') and ':=' in value:
                node, rule = _split_target(value)
                src, dst = rule.split(':=', 1)
                out.remaps.append((node, src, dst))
        i += 1
    return out


def node_name_matches(pattern: str, fqn: str) -> bool:
    """Return whether a parameter file's node name ``pattern`` applies to the node ``fqn``.

    rcl's rules: a missing leading ``/`` is added; ``/**`` stands for any number of
    namespace levels (none too), ``*`` for any part of one level.
    """
    tokens = [t for t in pattern.strip('/').split('/') if t]
    regex = ''
    for token in tokens:
        if token == '**':
            regex += '(?:/[^/]+)*'
        else:
            regex += '/' + '[^/]*'.join(re.escape(part) for part in token.split('*'))
    return re.fullmatch(regex or '/', fqn) is not None


def _sections(doc, path, where):
    """Yield (node name pattern, parameters mapping) of a parameter-file document."""
    if not isinstance(doc, Mapping):
        raise ParamFileError(f'{where}: not a ROS 2 parameter file: the document is a '
                             f'{type(doc).__name__}, not <node name>: {{{PARAMS_KEY}: ...}}')
    for key, value in doc.items():
        key = str(key)
        if key == PARAMS_KEY:
            if not path:
                raise ParamFileError(f'{where}: {PARAMS_KEY} must be under a node name')
            if not isinstance(value, Mapping) or not value:
                raise ParamFileError(f"{where}: '{'/'.join(path)}': {PARAMS_KEY} holds no "
                                     'parameters')
            yield '/'.join(p.strip('/') for p in path), value
        elif isinstance(value, Mapping):
            yield from _sections(value, path + [key], where)
        else:
            raise ParamFileError(f"{where}: '{'/'.join(path + [key])}' is not a node name "
                                 f'with {PARAMS_KEY} (got {type(value).__name__} '
                                 f'{_short(value)})')


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + '...'


def _flatten(params: Mapping, prefix: str, where: str, out: dict) -> dict:
    for key, value in params.items():
        name = f'{prefix}{key}'
        if isinstance(value, Mapping):
            _flatten(value, name + '.', where, out)
        elif name in out:
            raise ParamFileError(f"{where}: parameter '{name}' is given twice")
        else:
            out[name] = value
    return out


def check_file(path, fqn: str, own: Iterable[str], known: Iterable[str]) -> None:
    """Check the parameter file ``path`` for the node ``fqn``; raise ParamFileError.

    ``own``: the parameters the node takes (besides :data:`ROS_BUILTIN`); ``known``: those of
    every node of the package (what a wildcard section may hold).
    """
    own, known = set(own) | ROS_BUILTIN, set(known) | ROS_BUILTIN
    try:
        doc = load_file(path)
    except YamlFileError as exc:
        raise ParamFileError(str(exc)) from None
    found = []
    for pattern, params in _sections(doc, [], str(path)):
        names = _flatten(params, '', f"{path}: '{pattern}'", {})
        if not node_name_matches(pattern, fqn):
            continue
        found.append(pattern)
        valid = known if '*' in pattern else own
        for name in names:
            if name not in valid:
                whose = 'any abb_ros node' if '*' in pattern else fqn
                raise ParamFileError(f"{path}: '{pattern}': unknown parameter '{name}' "
                                     f'(not a parameter of {whose}{_near(name, valid)})')
    if not found:
        raise ParamFileError(f'{path}: no section applies to the node {fqn} (a section is '
                             f'<node name or /**>: {{{PARAMS_KEY}: ...}})')


def _near(name: str, valid) -> str:
    import difflib
    close = difflib.get_close_matches(name, sorted(valid), n=1, cutoff=0.75)
    return f'; did you mean {close[0]!r}?' if close else ''


def check_arguments(argv: Iterable[str], name: str, own: Iterable[str],
                    known: Iterable[str]) -> None:
    """Check every ``--params-file`` and ``-p`` of ``argv`` for the node first named ``name``.

    Raises ParamFileError naming the file (or ``-p``) and the key.
    """
    ros = parse_ros_arguments(argv)
    fqn = ros.node_name(name)
    own = set(own) | ROS_BUILTIN
    for path in ros.files:
        check_file(path, fqn, own, known)
    short = fqn.rsplit('/', 1)[-1]
    for node, key in ros.overrides:
        if node is None or node in (short, fqn, name):
            if key not in own:
                raise ParamFileError(f"-p {key}: unknown parameter '{key}' (not a parameter "
                                     f'of {fqn}{_near(key, own)})')

"""No module of the package reads another library's private state.

A private name (one leading underscore, not a dunder) belongs to the library that defines
it: the next release may rename it, and the code reading it then breaks silently or in the
field. Every module of ``abb_ros/`` is walked with :mod:`ast`:

- an import of a module with a private component (``rclpy._rclpy_pybind11``) or of a
  private name (``from mcap.writer import _Thing``) from outside the package is refused;
- an attribute access ``x._name`` is refused unless ``_name`` is a private name the package
  defines itself (a method, a class or module attribute, an attribute assigned as
  ``self._name``), so reaching into an rclpy node (``node._parameter_overrides``) or into
  name-mangled state (``writer._Writer__statistics``) fails.

namedtuple's ``_replace``, ``_asdict``, ``_fields`` and ``_make`` are public despite their
underscore (the standard library documents them so). The checker is tested on small
synthetic modules, so each kind of reach is seen to fail.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / 'abb_ros'
OWN = 'abb_ros'

PUBLIC_UNDERSCORED = frozenset({'_replace', '_asdict', '_fields', '_make', '_field_defaults'})
"""namedtuple's documented API: an underscore only to keep clear of field names."""


def _private(name: str) -> bool:
    return name.startswith('_') and not (name.startswith('__') and name.endswith('__'))


def defined_private_names(trees) -> set[str]:
    """Return every private name the modules ``trees`` define.

    Functions, classes, module and class attributes, attributes assigned on any object
    (``self._x = ...``) and import aliases. A name-mangled ``_Class__x`` is never one of them,
    so reading one through an attribute is always found.
    """
    names = set()
    for tree in trees:
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names.add(node.name)
            elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                names.add(node.id)
            elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
                names.add(node.attr)
            elif isinstance(node, ast.alias) and node.asname:
                names.add(node.asname)
    return {n for n in names if _private(n)}


def _foreign(module: str | None, level: int) -> bool:
    return level == 0 and module is not None and module.split('.')[0] not in (OWN, '__future__')


def private_reaches(tree: ast.AST, own_names: set[str]) -> list[str]:
    """Return a line per private reach into another library found in ``tree``."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if _foreign(alias.name, 0) and any(map(_private, alias.name.split('.'))):
                    found.append(f'{node.lineno}: import {alias.name}')
        elif isinstance(node, ast.ImportFrom) and _foreign(node.module, node.level):
            if any(map(_private, node.module.split('.'))):
                found.append(f'{node.lineno}: from {node.module} import ...')
            found += [f'{node.lineno}: from {node.module} import {alias.name}'
                      for alias in node.names if _private(alias.name)]
        elif isinstance(node, ast.Attribute) and _private(node.attr) \
                and node.attr not in own_names and node.attr not in PUBLIC_UNDERSCORED:
            found.append(f'{node.lineno}: .{node.attr}')
    return found


def _modules():
    return sorted(PACKAGE.rglob('*.py'))


def _reaches_in(sources: dict[str, str]) -> dict[str, list[str]]:
    trees = {name: ast.parse(text) for name, text in sources.items()}
    own = defined_private_names(trees.values())
    return {name: hits for name, tree in trees.items() if (hits := private_reaches(tree, own))}


def test_no_package_module_reads_another_librarys_private_state():
    """Every module of abb_ros/ uses other libraries through their public names only."""
    sources = {str(p.relative_to(ROOT)): p.read_text() for p in _modules()}
    found = _reaches_in(sources)
    assert not found, 'private state of another library read in:\n' + '\n'.join(
        f'  {name}:{hit}' for name, hits in found.items() for hit in hits)


@pytest.mark.parametrize('source', [
    'from rclpy._rclpy_pybind11 import RCLError\n',
    'import rclpy._rclpy_pybind11\n',
    'from mcap.writer import _ChunkBuilder\n',
    'def f(node):\n    return node._parameter_overrides\n',
    'def f(writer):\n    return writer._Writer__statistics\n',
    'class A:\n    def f(self):\n        return self._foreign_state\n',
])
def test_a_reach_into_private_state_is_found(source):
    """The checker flags each kind of reach: a private module, a private name, an attribute."""
    assert _reaches_in({'m.py': source})


@pytest.mark.parametrize('source', [
    'class A:\n    def __init__(self):\n        self._x = 1\n    def f(self, other):\n'
    '        return other._x\n',
    'def _helper():\n    pass\n\ndef f(module):\n    return module._helper()\n',
    'import collections\nP = collections.namedtuple("P", "a")\nq = P(1)._replace(a=2)\n',
    'from __future__ import annotations\nfrom . import _own\nx = type(1).__name__\n',
])
def test_the_packages_own_private_names_pass(source):
    """Private names the package defines itself, namedtuple's API and dunders are allowed."""
    assert not _reaches_in({'m.py': source})

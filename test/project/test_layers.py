"""The layer table of docs/architecture.md holds: no module imports what its layer may not.

The table's rows (``| `abb_ros/<layer>/` | job | may import |``) are parsed into rules, and
every module of the package is walked with :mod:`ast`, imports inside functions included.
The checker itself is tested on small synthetic modules, so an upward import is seen to fail.
"""

from __future__ import annotations

import ast
import fnmatch
import re
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / 'abb_ros'
ARCHITECTURE = ROOT / 'docs' / 'architecture.md'

ALLOW, LAZY, NEVER = 'allowed', 'only inside functions', 'never'


@dataclass
class LayerRule:
    """What one layer may import: {name: ALLOW, LAZY or NEVER}, layers and modules apart."""

    layers: dict[str, str] = field(default_factory=dict)
    modules: dict[str, str] = field(default_factory=dict)


def _layer_of_cell(cell: str) -> str | None:
    """Return the layer a first cell names: `abb_ros/model/` -> model, `abb_ros/cli.py` -> cli."""
    match = re.fullmatch(r'`abb_ros/(\w+)(?:/|\.py)`', cell.strip())
    return match.group(1) if match else None


def parse_layer_table(markdown: str) -> dict[str, LayerRule]:
    """Return {layer: rule} from the table of the section "## Layers" of ``markdown``."""
    section = markdown.split('\n## Layers\n', 1)[1].split('\n## ', 1)[0]
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip('|').split('|')]
        if line.startswith('|') and len(cells) == 3 and _layer_of_cell(cells[0]):
            rows.append((_layer_of_cell(cells[0]), cells[2]))
    layers = {layer for layer, _ in rows}
    rules = {}
    for layer, column in rows:
        rule = LayerRule()
        for clause in column.split(';'):
            kind = NEVER if clause.strip().startswith('never') else \
                LAZY if LAZY in clause else ALLOW
            for name in re.findall(r'`([^`]+)`', clause):
                (rule.layers if name in layers else rule.modules)[name] = kind
        rules[layer] = rule
    return rules


@dataclass(frozen=True)
class Import:
    """One imported module: its full name, line and whether it sits in a function body."""

    module: str
    line: int
    in_function: bool


def imports_of(source: str, module: str) -> list[Import]:
    """Return every import of ``source`` (the module ``module``), relative ones resolved."""
    package = module.split('.')
    found = []

    def visit(node, in_function):
        for child in ast.iter_child_nodes(node):
            inner = in_function or isinstance(
                child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            if isinstance(child, ast.Import):
                found.extend(Import(a.name, child.lineno, in_function) for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ''
                if child.level:
                    parent = package[:len(package) - child.level]
                    base = '.'.join(parent + ([base] if base else []))
                if base == 'abb_ros':   # from abb_ros import model: the names are modules
                    found.extend(Import(f'abb_ros.{a.name}', child.lineno, in_function)
                                 for a in child.names)
                elif base != '__future__':
                    found.append(Import(base, child.lineno, in_function))
            visit(child, inner)

    visit(ast.parse(source), False)
    return found


def _decision(names: dict[str, str], module: str) -> str | None:
    """Return the kind of the most specific name of ``names`` matching ``module``."""
    parts = module.split('.')
    for n in range(len(parts), 0, -1):
        prefix = '.'.join(parts[:n])
        kinds = [kind for name, kind in names.items() if fnmatch.fnmatchcase(prefix, name)]
        if kinds:
            return NEVER if NEVER in kinds else LAZY if LAZY in kinds else ALLOW
    return None


def violations(rules: dict[str, LayerRule], path: str, source: str) -> list[str]:
    """Return one line per import of ``source`` that the table refuses.

    ``path`` is the module's path inside the package, e.g. ``model/parameters/params.py``.
    """
    parts = Path(path).with_suffix('').parts
    layer = parts[0]
    module = '.'.join(('abb_ros',) + parts)
    if len(parts) == 1 and layer == '__init__':
        rule = LayerRule()   # the package's own __init__ imports no layer
    elif layer not in rules:
        return [f'{path}: no row for layer {layer!r} in the layer table']
    else:
        rule = rules[layer]
    out = []
    for imp in imports_of(source, module):
        where = f'{path}:{imp.line}: {layer} imports {imp.module}'
        top = imp.module.split('.')
        if top[0] == 'abb_ros':
            target = top[1] if len(top) > 1 else None
            if target is None or target == layer:
                continue
            kind = rule.layers.get(target)
        else:
            kind = _decision(rule.modules, imp.module)
            if kind is None:
                continue
        if kind is None or kind == NEVER:
            out.append(where + ' (not allowed by the layer table)')
        elif kind == LAZY and not imp.in_function:
            out.append(where + ' at module level (only inside functions)')
    return out


def _package_modules():
    return sorted(PACKAGE.rglob('*.py'))


RULES = parse_layer_table(ARCHITECTURE.read_text(encoding='utf-8'))


def test_the_table_has_a_row_for_every_layer_of_the_package():
    """Every package directory and top-level module of abb_ros is a row, and no more."""
    layers = {p.relative_to(PACKAGE).parts[0] for p in _package_modules()
              if len(p.relative_to(PACKAGE).parts) > 1}
    layers |= {p.stem for p in PACKAGE.glob('*.py') if p.stem != '__init__'}
    assert layers == set(RULES), 'docs/architecture.md, ## Layers: a row per layer'


def test_no_module_imports_what_its_layer_may_not():
    """The package as it stands keeps the table."""
    found = []
    for path in _package_modules():
        rel = path.relative_to(PACKAGE).as_posix()
        found += violations(RULES, rel, path.read_text(encoding='utf-8'))
    assert found == [], '\n'.join(found)


def test_the_model_imports_no_other_layer_and_nothing_imports_the_dispatcher():
    """The rules the rest rely on are in the table as read."""
    assert not RULES['model'].layers
    assert all('cli' not in rule.layers for rule in RULES.values())
    assert RULES['model'].modules['rclpy'] == NEVER and RULES['model'].modules['yaml'] == NEVER


# ---- the checker on synthetic modules -----------------------------------------------------

TABLE = '''# Architecture

## Layers

| layer | job | may import |
|---|---|---|
| `abb_ros/model/` | physics | `numpy`; never `rclpy`, `*_msgs`, `yaml` |
| `abb_ros/io/` | formats | `model`, `yaml`; `rclpy.serialization` only inside functions; \
never `rclpy` |
| `abb_ros/nodes/` | adapters | `rclpy`, `model`, `io` |
| `abb_ros/cli.py` | dispatcher | `model`, `nodes` (only for this test) |

## Next section

| `abb_ros/plots/` | not a row of the layer table | `nodes` |
'''


@pytest.fixture
def rules():
    """Return the rules of the synthetic table."""
    return parse_layer_table(TABLE)


def test_checker_reads_the_rows_of_the_layers_section_only(rules):
    """Rows after the section are not rules; layers and modules are told apart."""
    assert set(rules) == {'model', 'io', 'nodes', 'cli'}
    assert rules['io'].layers == {'model': ALLOW}
    assert rules['io'].modules == {'yaml': ALLOW, 'rclpy.serialization': LAZY, 'rclpy': NEVER}
    assert rules['cli'].layers == {'model': ALLOW, 'nodes': ALLOW}


@pytest.mark.parametrize('source', [
    'from abb_ros.nodes import simulator\n',
    'import abb_ros.io.files.safe_yaml\n',
    'def f():\n    from abb_ros.io.files.safe_yaml import load_file\n',
    'from abb_ros import nodes\n',
    'from ..nodes.recorder import Recorder\n',
    'import rclpy\n',
    'from std_msgs.msg import Float64\n',
    'def f():\n    import yaml\n',
])
def test_checker_fails_on_an_import_running_up_from_the_model(rules, source):
    """An upward or forbidden import fails, at module level or inside a function."""
    found = violations(rules, 'model/fake.py', source)
    assert len(found) == 1 and found[0].startswith('model/fake.py:'), found


@pytest.mark.parametrize('source', [
    'import math\nimport numpy as np\n',
    'from abb_ros.model.parameters.params import DriveParams\n',
    'from . import params\nfrom .state import rbar\n',
    'import scipy.linalg\n',
])
def test_checker_passes_what_the_model_may_import(rules, source):
    """The standard library, allowed modules and the layer's own modules pass."""
    assert violations(rules, 'model/fake.py', source) == []


def test_checker_tells_a_lazy_import_from_one_at_module_level(rules):
    """A module allowed only inside functions fails at module level."""
    lazy = 'def read():\n    from rclpy.serialization import deserialize_message\n'
    assert violations(rules, 'io/fake.py', lazy) == []
    found = violations(rules, 'io/fake.py', 'from rclpy.serialization import serialize_message\n')
    assert len(found) == 1 and 'only inside functions' in found[0]
    assert len(violations(rules, 'io/fake.py', 'from rclpy.node import Node\n')) == 1


def test_checker_refuses_a_layer_without_a_row_and_imports_of_the_dispatcher(rules):
    """A module in no row fails, and so does an import of a layer no row names."""
    assert violations(rules, 'plots/fake.py', 'import numpy\n') == [
        "plots/fake.py: no row for layer 'plots' in the layer table"]
    assert len(violations(rules, 'nodes/fake.py', 'from abb_ros.cli import main\n')) == 1
    assert violations(rules, 'cli.py', 'from abb_ros.nodes import simulator\n') == []


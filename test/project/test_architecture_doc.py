"""docs/architecture.md names the package as it is: every module in its module list, no module
that does not exist, and every kernel module in the table of where the equations live."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / 'abb_ros'
DOC = ROOT / 'docs' / 'architecture.md'
BOOKKEEPING_KERNELS = {'model/dynamics/kernels/layout.py'}
"""Kernel modules that hold no equation (packed inputs and scratch), so not in the table."""


def section(text: str, title: str) -> str:
    """Return the text of the ``## title`` section (up to the next ``## ``)."""
    start = text.index(f'\n## {title}\n')
    end = text.find('\n## ', start + 1)
    return text[start:end if end >= 0 else len(text)]


def package_modules(package: Path = PACKAGE) -> set[str]:
    """Return every module of the package as a path relative to it, ``__init__`` files aside."""
    return {p.relative_to(package).as_posix() for p in package.rglob('*.py')
            if p.name != '__init__.py' and '__pycache__' not in p.parts}


OUTSIDE = ('test/', 'benchmarks/', 'scripts/')
"""Folders beside the package whose files the doc may name too."""


def named_modules(text: str) -> set[str]:
    """Return the package module paths (`` `dir/name.py` ``, `` `cli.py` ``) a text names."""
    return {name for name in re.findall(r'`((?:[a-z_]+/)*[a-z_0-9]+\.py)`', text)
            if not name.startswith(OUTSIDE)}


def unnamed_and_unknown(text: str, modules: set[str]) -> tuple[set[str], set[str]]:
    """Return (modules the text does not name, names in the text that are no module)."""
    named = named_modules(text)
    return modules - named, named - modules


def test_the_module_list_names_every_module_of_the_package():
    missing, unknown = unnamed_and_unknown(section(DOC.read_text(), 'Modules'),
                                           package_modules())
    assert not missing, f'docs/architecture.md, "## Modules", does not name {sorted(missing)}'
    assert not unknown, f'docs/architecture.md, "## Modules", names no module {sorted(unknown)}'


def test_the_equation_table_names_every_kernel_module():
    table = section(DOC.read_text(), 'Where the equations live')
    kernels = {m for m in package_modules() if m.startswith('model/dynamics/kernels/')}
    missing = kernels - BOOKKEEPING_KERNELS - named_modules(table)
    assert not missing, f'the equation table does not name {sorted(missing)}'


def test_the_check_fails_on_a_missing_or_a_made_up_module(tmp_path):
    (tmp_path / 'model').mkdir()
    for name in ('model/state.py', 'model/floquet.py', 'model/__init__.py', 'cli.py'):
        (tmp_path / name).write_text('')
    modules = package_modules(tmp_path)
    assert modules == {'model/state.py', 'model/floquet.py', 'cli.py'}
    text = '- `model/state.py` (the state layout), `cli.py`, `model/linear.py`'
    assert unnamed_and_unknown(text, modules) == ({'model/floquet.py'}, {'model/linear.py'})


MODEL_TOP_LEVEL_LIMIT = 12
"""Modules directly in ``model/``; more, and the concept they share wants a sub-package."""


def test_the_model_keeps_its_modules_in_sub_packages_by_concept():
    """A thirteenth module directly in model/ fails: new physics joins its concept's room."""
    top = {m for m in package_modules() if m.startswith('model/') and m.count('/') == 1}
    assert len(top) <= MODEL_TOP_LEVEL_LIMIT, (
        f'model/ holds {len(top)} modules directly ({sorted(top)}); at most '
        f'{MODEL_TOP_LEVEL_LIMIT}: put each in the sub-package of its concept')

"""The code follows ament's flake8 rules (99 columns, pyflakes, pycodestyle), sorted imports and
numpy-style docstrings in the package, checked by ruff (ruff.toml)."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_code_passes_ruff_with_the_ament_line_length():
    ruff = shutil.which('ruff', path=str(Path(sys.executable).parent))
    if ruff is None:
        pytest.fail('ruff is not installed in the test environment (requirements.txt pins it)')
    proc = subprocess.run([ruff, 'check', '--output-format', 'concise', 'abb_ros', 'test',
                           'benchmarks', 'scripts', 'launch', 'setup.py'], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr


MAX_MODULE_LINES = 450
"""A module of the package longer than this does several jobs: split it by concept."""


def test_no_module_of_the_package_is_over_450_lines():
    long = {str(path.relative_to(ROOT)): n for path in (ROOT / 'abb_ros').rglob('*.py')
            if (n := len(path.read_text().splitlines())) > MAX_MODULE_LINES}
    assert long == {}, f'modules over {MAX_MODULE_LINES} lines: {long}'

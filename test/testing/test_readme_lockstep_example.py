"""The README's test of a user's controller (section "Controllers in the loop") is complete
and passes: its code block is run as it stands, with the plugin's lockstep_plant fixture."""

from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[2] / 'README.md'

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def readme_example() -> str:
    section = README.read_text().split('## Controllers in the loop')[1].split('\n## ')[0]
    return section.split('```python\n')[1].split('```')[0]


def test_the_readme_example_is_a_complete_test_under_30_lines_and_passes(lockstep_plant):
    code = readme_example()
    assert len(code.splitlines()) < 30
    namespace = {}
    exec(compile(code, str(README), 'exec'), namespace)  # noqa: S102 - our own README
    tests = [name for name in namespace if name.startswith('test_')]
    assert len(tests) == 1
    namespace[tests[0]](lockstep_plant)

"""Commit messages since the house rules were set keep them: a subject of at most 72
characters in the imperative, one change per commit (no subjects joined by "; "), and a body
that says why (merge commits aside). Skipped, with the reason, outside a git checkout or in a
shallow clone that lacks the commit the rules start from."""

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RULES_FROM = 'f354916'
"""The last commit before the rules; every commit after it must keep them."""
MAX_SUBJECT = 72
NOT_IMPERATIVE = re.compile(
    r'^(Add|Fix|Make|Move|Remove|Rename|Update|Change|Improve|Refactor|Split|Use)'
    r'(s|ed|ing)\b|^Made\b')
"""Subjects that describe (Adds, Added, Adding) rather than command (Add)."""


def git(*args: str) -> str:
    return subprocess.run(['git', *args], cwd=ROOT, capture_output=True, text=True,
                          check=True, timeout=60).stdout


def commits_since_the_rules() -> list[tuple[str, str, str, int]]:
    """Return (hash, subject, body, parents) of every commit after RULES_FROM."""
    if shutil.which('git') is None or not (ROOT / '.git').exists():
        pytest.skip('not a git checkout')
    try:
        git('cat-file', '-e', f'{RULES_FROM}^{{commit}}')
    except subprocess.CalledProcessError:
        pytest.skip(f'{RULES_FROM} is not in this clone (shallow?)')
    log = git('log', '--format=%h%x00%s%x00%b%x00%p%x01', f'{RULES_FROM}..HEAD')
    out = []
    for entry in filter(str.strip, log.split('\x01')):
        sha, subject, body, parents = entry.strip('\n').split('\x00')
        out.append((sha, subject, body.strip(), len(parents.split())))
    return out


def rule_breaks(subject: str, body: str, parents: int) -> list[str]:
    """Return the rules a commit message breaks (empty when it keeps them all)."""
    breaks = []
    if len(subject) > MAX_SUBJECT:
        breaks.append(f'subject of {len(subject)} characters (at most {MAX_SUBJECT})')
    if '; ' in subject:
        breaks.append('several changes joined by "; " in the subject')
    if NOT_IMPERATIVE.match(subject):
        breaks.append('subject not in the imperative')
    if parents < 2 and not body:
        breaks.append('no body saying why')
    return breaks


def test_every_commit_since_the_rules_keeps_them():
    broken = {f'{sha} {subject!r}': rule_breaks(subject, body, parents)
              for sha, subject, body, parents in commits_since_the_rules()}
    broken = {k: v for k, v in broken.items() if v}
    assert not broken, broken


def test_the_rules_catch_a_long_joined_subject_without_body():
    assert len(rule_breaks('Added a thing; fixed another thing and ' + 'x' * 60, '', 1)) == 4
    assert rule_breaks('Split the contact kernels into their own module', 'Why.', 1) == []
    assert rule_breaks('Merge the docs branch', '', 2) == []

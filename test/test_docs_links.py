"""Every relative link in README.md and docs/*.md leads somewhere that exists.

Links to the web are not checked, nor links into docs/figures (another test covers the figures).
A link with an anchor (``file.md#section``, ``#section``) must name a heading of that file, with
GitHub's rule for heading anchors.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / 'README.md', *sorted((ROOT / 'docs').glob('*.md'))]

_LINK = re.compile(r'!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+"[^"]*")?\s*\)')
_FENCE = re.compile(r'^(```|~~~).*?^\1', re.M | re.S)
_CODE = re.compile(r'`[^`\n]*`')
_HEADING = re.compile(r'^#{1,6}\s+(.*?)\s*#*\s*$', re.M)
_EXTERNAL = re.compile(r'^[a-z][a-z0-9+.-]*:', re.I)   # http:, https:, mailto:, ...


def _prose(text: str) -> str:
    """The text without fenced code blocks and inline code, where links are not links."""
    return _CODE.sub('', _FENCE.sub('', text))


def links(text: str) -> list[str]:
    return _LINK.findall(_prose(text))


def anchors(text: str) -> set[str]:
    """GitHub's heading anchors: lower case, punctuation dropped, spaces to hyphens, and
    ``-1``, ``-2``, ... on repeats."""
    seen: dict[str, int] = {}
    out = set()
    for title in _HEADING.findall(_FENCE.sub('', text)):
        slug = re.sub(r'[^\w\- ]', '', title.replace('`', '').strip().lower()).replace(' ', '-')
        count = seen.get(slug, 0)
        seen[slug] = count + 1
        out.add(slug if count == 0 else f'{slug}-{count}')
    return out


def _checked(doc: Path):
    for target in links(doc.read_text(encoding='utf-8')):
        if _EXTERNAL.match(target):
            continue
        path, _, anchor = target.partition('#')
        resolved = (doc.parent / path).resolve() if path else doc
        if path and (ROOT / 'docs' / 'figures') in resolved.parents:
            continue
        yield target, resolved, anchor


@pytest.mark.parametrize('doc', DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_points_to_an_existing_file(doc):
    missing = [target for target, resolved, _ in _checked(doc) if not resolved.exists()]
    assert not missing, f'{doc.relative_to(ROOT)} links to missing files: {missing}'


@pytest.mark.parametrize('doc', DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_link_anchor_names_a_heading_of_its_file(doc):
    bad = [target for target, resolved, anchor in _checked(doc)
           if anchor and resolved.suffix == '.md' and resolved.exists()
           and anchor not in anchors(resolved.read_text(encoding='utf-8'))]
    assert not bad, f'{doc.relative_to(ROOT)} links to missing headings: {bad}'


def test_the_link_checker_sees_links_and_anchors_as_github_does():
    text = ('# How to add ...\n## Simulator node (`abb_simulator`)\n## Parameters, Eq. (39)\n'
            '## Parameters, Eq. (39)\n[a](x.md#y) ![b](docs/figures/f.png) `[c](z.md)`\n'
            '```\n[d](w.md)\n# not a heading\n```\n[e](https://example.com)\n')
    assert links(text) == ['x.md#y', 'docs/figures/f.png', 'https://example.com']
    assert anchors(text) == {'how-to-add-', 'simulator-node-abb_simulator',
                             'parameters-eq-39', 'parameters-eq-39-1'}


def test_no_document_cites_a_file_outside_the_repository():
    outside = [(doc.name, target) for doc in DOCS for target, resolved, _ in _checked(doc)
               if ROOT not in resolved.parents and resolved != ROOT]
    assert not outside, f'links leave the repository: {outside}'

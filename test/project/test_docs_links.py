"""Check that every link, cited README section and cited docs path exists.

Every relative link in README.md and docs/*.md, every README section and every docs/*.md or
docs/figures path cited anywhere in the repository.

Links to the web are not checked, nor links into docs/figures (another test covers the
figures). A link with an anchor (``file.md#section``, ``#section``) must name a heading of
that file, with GitHub's rule for heading anchors.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / 'README.md', *sorted((ROOT / 'docs').glob('*.md'))]

_LINK = re.compile(r'!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+"[^"]*")?\s*\)')
_FENCE = re.compile(r'^(```|~~~).*?^\1', re.M | re.S)
_CODE = re.compile(r'`[^`\n]*`')
_HEADING = re.compile(r'^#{1,6}\s+(.*?)\s*#*\s*$', re.M)
_EXTERNAL = re.compile(r'^[a-z][a-z0-9+.-]*:', re.I)   # http:, https:, mailto:, ...


def _prose(text: str) -> str:
    """Return the text without fenced code blocks and inline code (no links there)."""
    return _CODE.sub('', _FENCE.sub('', text))


def links(text: str) -> list[str]:
    """Return the targets of the Markdown links and images of ``text``."""
    return _LINK.findall(_prose(text))


def anchors(text: str) -> set[str]:
    """Return GitHub's heading anchors of ``text``.

    Lower case, punctuation dropped, spaces to hyphens, and ``-1``, ``-2``, ... on repeats.
    """
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
    """Find every relative link's file in the repository."""
    missing = [target for target, resolved, _ in _checked(doc) if not resolved.exists()]
    assert not missing, f'{doc.relative_to(ROOT)} links to missing files: {missing}'


@pytest.mark.parametrize('doc', DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_link_anchor_names_a_heading_of_its_file(doc):
    """Find every link's anchor among the headings of the file it links to."""
    bad = [target for target, resolved, anchor in _checked(doc)
           if anchor and resolved.suffix == '.md' and resolved.exists()
           and anchor not in anchors(resolved.read_text(encoding='utf-8'))]
    assert not bad, f'{doc.relative_to(ROOT)} links to missing headings: {bad}'


def test_the_link_checker_sees_links_and_anchors_as_github_does():
    """Read links and heading anchors as GitHub renders them."""
    text = ('# How to add ...\n## Simulator node (`abb_simulator`)\n## Parameters, Eq. (39)\n'
            '## Parameters, Eq. (39)\n[a](x.md#y) ![b](docs/figures/f.png) `[c](z.md)`\n'
            '```\n[d](w.md)\n# not a heading\n```\n[e](https://example.com)\n')
    assert links(text) == ['x.md#y', 'docs/figures/f.png', 'https://example.com']
    assert anchors(text) == {'how-to-add-', 'simulator-node-abb_simulator',
                             'parameters-eq-39', 'parameters-eq-39-1'}


def test_no_document_cites_a_file_outside_the_repository():
    """Keep every relative link inside the repository."""
    outside = [(doc.name, target) for doc in DOCS for target, resolved, _ in _checked(doc)
               if ROOT not in resolved.parents and resolved != ROOT]
    assert not outside, f'links leave the repository: {outside}'


# A citation of a README section in prose or comments: README 'Title', README "Title",
# README section 'Title', README, section "Title" (a line break and comment marks may fall
# between the words). README.md#anchor links are checked above.
_README_CITATION = re.compile(
    r'README(?:\.md)?[\s#,:]*(?:\(?\s*section[\s#]*)?[\'"\u201c]([^\'"\u201d\n]{2,80})'
    r'[\'"\u201d]'
    r'|README[^.\n]{0,60}?\bsection[\s#]+[\'"\u201c]([^\'"\u201d\n]{2,80})[\'"\u201d]')
CITING = ['abb_ros', 'scripts', '.ci', 'docs', 'benchmarks', 'test', 'launch', 'config',
          'README.md', 'CHANGELOG.md', 'requirements.txt', 'setup.py', 'setup.cfg', 'package.xml']
_TEXT = {'.py', '.md', '.txt', '.yaml', '.yml', '.cfg', '.xml', '.toml', '', '.sh'}


def readme_citations(text: str) -> list[str]:
    """Return the README section titles that ``text`` cites."""
    text = text.replace("README's", 'README')
    return [a or b for a, b in _README_CITATION.findall(text)]


def _citing_files():
    for name in CITING:
        path = ROOT / name
        files = sorted(path.rglob('*')) if path.is_dir() else [path]
        for file in files:
            if (file.is_file() and file.suffix in _TEXT and '__pycache__' not in file.parts
                    and 'node_modules' not in file.parts   # npm's packages: not ours
                    and file != Path(__file__).resolve()):
                yield file


def _citing_texts():
    for file in _citing_files():
        try:
            yield file, file.read_text(encoding='utf-8')
        except UnicodeDecodeError:
            continue


def test_every_cited_readme_section_exists():
    """Find every README section named in the code, scripts, CI and docs among its headings."""
    titles = {title.replace('`', '').strip().lower()
              for title in _HEADING.findall(_FENCE.sub('', (ROOT / 'README.md').read_text()))}
    cited = {}
    for file, text in _citing_texts():
        for title in readme_citations(text):
            cited.setdefault(title, []).append(str(file.relative_to(ROOT)))
    assert cited, 'no README citation found: the pattern misses the forms in use'
    missing = {title: where for title, where in cited.items()
               if title.replace('`', '').strip().lower() not in titles}
    assert not missing, f'README sections that do not exist: {missing}'


def test_the_citation_pattern_sees_the_forms_in_use():
    """Read the forms of README citations used in comments, docstrings and prose."""
    text = ("# The test command of README\n# 'Set-up: two commands'.\n"
            'see README section "A five-minute tour" and README, "Design studies on Dask";\n'
            "The README's test of a user's controller (section \"Controllers in the loop\")\n"
            'the README says so. README.md is the entry point.\n')
    assert readme_citations(text) == ['Set-up: two commands', 'A five-minute tour',
                                      'Design studies on Dask', 'Controllers in the loop']


# A repository path of a document or figure: docs/<name>.md, docs/figures/... (not part of a
# longer path such as an install tree). A path named as the old side of a rename (the
# changelog's "`docs/a.md` is now ...", "(was `docs/a.md`)") is history, not a citation.
_DOC_PATH = re.compile(r'(?<![\w./-])docs/(?:figures(?:/[\w.-]+)*|[\w-]+\.md)')
_RENAMED_AFTER = re.compile(r'[`\'"]?\s+is now\b')
_RENAMED_BEFORE = re.compile(r'\b(?:was|were)\s+[`\'"]?$')


def doc_paths(text: str) -> list[str]:
    """Return the docs/*.md and docs/figures paths that ``text`` cites, in order."""
    out = []
    for match in _DOC_PATH.finditer(text):
        if (_RENAMED_AFTER.match(text, match.end())
                or _RENAMED_BEFORE.search(text[max(0, match.start() - 12):match.start()])):
            continue
        out.append(match.group().rstrip('./'))
    return out


def missing_doc_paths(text: str) -> list[str]:
    """Return the paths of :func:`doc_paths` that do not exist in the repository."""
    return [path for path in doc_paths(text) if not (ROOT / path).exists()]


def test_every_cited_docs_path_exists():
    """Find every docs/*.md and docs/figures path named in code, scripts, CI and docs."""
    missing = {}
    for file, text in _citing_texts():
        for path in missing_doc_paths(text):
            missing.setdefault(path, []).append(str(file.relative_to(ROOT)))
    assert not missing, f'cited documents or figures that do not exist: {missing}'


def test_the_docs_path_check_fails_on_a_made_up_citation():
    """Read the cited paths as written, and report the made-up ones."""
    text = ('See docs/cli.md, the figure docs/figures/fig4a.png and `docs/figures/sweep/`.\n'
            '# details: docs/no_such_page.md; plot in docs/figures/none/x.png.\n'
            '- `docs/old_name.md` is now `docs/sweep.md` (was `docs/older.md`).\n'
            'not a citation: /work/wt-docs/benchmarks/a.md, share/abb_ros/docs/cli.md\n')
    assert doc_paths(text) == ['docs/cli.md', 'docs/figures/fig4a.png', 'docs/figures/sweep',
                               'docs/no_such_page.md', 'docs/figures/none/x.png',
                               'docs/sweep.md']
    assert missing_doc_paths(text) == ['docs/no_such_page.md', 'docs/figures/none/x.png']

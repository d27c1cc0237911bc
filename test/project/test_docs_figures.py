"""The figures of the documentation: every image a Markdown file shows exists, and every PNG in
docs/figures is shown somewhere (scripts/make_figures.py regenerates them)."""

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
FIGURES = REPO / 'docs' / 'figures'
MARKDOWN_IMAGE = re.compile(r'!\[[^\]]*\]\(\s*<?([^)\s>]+)')
HTML_IMAGE = re.compile(r'<img\b[^>]*\bsrc\s*=\s*["\']([^"\']+)["\']', re.IGNORECASE)
NOT_SHOWN = frozenset()
"""PNGs in docs/figures that no Markdown file needs to show (none today)."""


def markdown_files():
    """README.md and every Markdown file of the repository outside hidden, build and npm dirs."""
    return sorted(p for p in REPO.rglob('*.md')
                  if not any(part.startswith('.') or part in ('build', 'install', 'log',
                                                                     'node_modules')
                             for part in p.relative_to(REPO).parts))


def image_references():
    """(markdown file, target as written, resolved path) for every local image."""
    refs = []
    for md in markdown_files():
        text = md.read_text(encoding='utf-8')
        for target in MARKDOWN_IMAGE.findall(text) + HTML_IMAGE.findall(text):
            if re.match(r'^[a-z]+:', target):
                continue  # http(s):, data: -- not files of the repository
            path = target.split('#')[0].split('?')[0]
            refs.append((md, target, (md.parent / path).resolve()))
    return refs


def test_the_image_patterns_find_markdown_and_html_images():
    text = '![a](docs/x.png) and <img width="300" src="docs/y.png"> and [link](z.png)'
    assert MARKDOWN_IMAGE.findall(text) + HTML_IMAGE.findall(text) == ['docs/x.png',
                                                                       'docs/y.png']


def test_every_figure_referenced_in_the_markdown_files_exists():
    refs = image_references()
    assert refs, 'no image found in any Markdown file'
    missing = [f'{md.relative_to(REPO)}: {target}' for md, target, path in refs
               if not path.is_file()]
    assert not missing, 'images that do not exist:\n' + '\n'.join(missing)


def test_every_png_under_docs_figures_is_shown_in_a_markdown_file():
    shown = {path for _, _, path in image_references()}
    pngs = {p.resolve() for p in FIGURES.rglob('*.png')}
    assert pngs, 'docs/figures holds no PNG'
    orphans = sorted(str(p.relative_to(REPO)) for p in pngs - shown
                     if str(p.relative_to(REPO)) not in NOT_SHOWN)
    assert not orphans, ('PNGs no Markdown file shows (show them or add them to NOT_SHOWN):\n'
                         + '\n'.join(orphans))


def test_figure_titles_name_the_key_parameters_and_the_washers():
    from abb_ros.model.parameters.params import DriveParams, apply_settings
    from abb_ros.plots.labels import parameter_text
    p3, omega = apply_settings(DriveParams(), {'mbar': 0.03, 'c': 0.66, 'wbar': 2.7})
    text = parameter_text(p3, p3.wbar(omega))
    assert text == (r'$\bar{\omega}$ = 2.7, $\zeta$ = 0.025 (metal washers), '
                    r'$\bar{\varepsilon}$ = 0.0167, $\bar{m}$ = 0.03, n = 2')
    # The paper's "zeta = 0.1 (for rubber washers)" is c = 2.64 kg/s; Table 1 says 2.53.
    rubber, _ = apply_settings(DriveParams(), {'zeta': 0.1})
    assert '(rubber washers)' in parameter_text(rubber)
    odd, _ = apply_settings(DriveParams(), {'zeta': 0.05})
    assert 'washers' not in parameter_text(odd)
    without = parameter_text(p3.replace(n=0), omit=('wbar',))
    assert without.endswith('n = 0 (without ABB)') and r'\bar{m}' not in without
    assert r'\bar{m}' not in parameter_text(p3, 2.7, omit=('mbar', 'wbar'))

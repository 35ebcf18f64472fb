"""
The site reads easily: short sentences where a reader follows steps, short pages.

Sentences are counted roughly: code blocks, tables, headings, images and
comments left out; inline code one word; a list item ends a sentence; a
sentence ends at ``.``, ``?`` or ``!`` before a capital. Pages are classed
by the site's navigation (``mkdocs.yml``).
"""

from pathlib import Path
import re
import statistics

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / 'docs'
#: The evidence pages: figures and their method, long by nature.
EVIDENCE = {'calibration.md', 'walks.md', 'generalisation.md', 'performance.md',
            'close-the-loop.md'}
MAX_PAGE_WORDS = 2500


def sentence_lengths(markdown):
    """Return the word count of every sentence of a page's prose."""
    text = re.sub(r'```.*?```', '', markdown, flags=re.S)
    text = re.sub(r'<!--.*?-->', '', text, flags=re.S)
    out = []
    for block in re.split(r'\n\s*\n', text):
        lines = [line for line in block.splitlines()
                 if not line.lstrip().startswith(('|', '#', '!['))]
        for item in re.split(r'\n(?=\s*(?:[-*]|\d+\.)\s)', '\n'.join(lines)):
            item = re.sub(r'^\s*(?:[-*]|\d+\.)\s+', '', item)
            item = re.sub(r'\]\([^)]*\)', ']', item)
            item = ' '.join(re.sub(r'`[^`]*`', 'CODE', item).split())
            out += [len(s.split()) for s in re.split(r'(?<=[.!?])\s+(?=[A-Z(*"\'])', item)
                    if s.split()]
    return out


def nav_pages():
    """Return {section title: [page path]} of the site's navigation."""
    text = (ROOT / 'mkdocs.yml').read_text()
    nav = yaml.safe_load('nav:' + text.split('\nnav:')[1])['nav']
    out = {}
    for entry in nav:
        for title, pages in entry.items():
            pages = pages if isinstance(pages, list) else [{title: pages}]
            out[title] = [path for page in pages for path in page.values()]
    return out


def test_the_counter_counts():
    page = ('# Title\n\nOne two three. Four five (six).\n\n- a list item\n- `code span` here\n\n'
            '| a | table |\n\n```\nnot. counted. here.\n```\n')
    assert sentence_lengths(page) == [3, 3, 3, 2]


@pytest.mark.parametrize('path', nav_pages()['Tutorials'] + nav_pages()['How-to guides'])
def test_steps_are_told_in_short_sentences(path):
    lengths = sentence_lengths((DOCS / path).read_text())
    assert statistics.median(lengths) < 20, f'{path}: median sentence {statistics.median(lengths)}'
    assert max(lengths) <= 50, f'{path}: a sentence of {max(lengths)} words'


@pytest.mark.parametrize('path', [p for p in nav_pages()['Explanation'] if p not in EVIDENCE])
def test_explanation_is_told_in_sentences_a_reader_follows(path):
    lengths = sentence_lengths((DOCS / path).read_text())
    assert statistics.median(lengths) <= 20, \
        f'{path}: median sentence {statistics.median(lengths)}'
    assert max(lengths) <= 50, f'{path}: a sentence of {max(lengths)} words'


def test_no_page_but_the_evidence_is_long():
    long = {}
    for path in DOCS.rglob('*.md'):
        name = path.relative_to(DOCS).as_posix()
        if name not in EVIDENCE:
            words = len(path.read_text().split())
            if words > MAX_PAGE_WORDS:
                long[name] = words
    assert not long, f'pages over {MAX_PAGE_WORDS} words: {long}'

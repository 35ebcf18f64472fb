"""
The built site reads at 1280 px: no collapsed list, nothing wider than the page.

What a reader met in Chromium at 1280 x 1000 px: lists run into the
paragraph before them (Markdown needs a blank line first), tables and code
that scroll sideways, link texts that are repository paths. These tests
read the built HTML. The width of a table is estimated from its words: a
column is as wide as its longest unbreakable word (text breaks at spaces
and after hyphens, code at spaces) plus its cell's margins, and the table
must fit the article's 688 px plus the 32 px its wrapper reaches into the
margins. The constants were set against Chromium's own layout of every
table of the site (``tools/site_overflow.py``, run by ``make
site-screenshots``, measures it): at 6.4 px a character the estimate is at
most about 30 px wide of the real width, and every table that scrolled
was caught.
"""

import html
from pathlib import Path
import re

import pytest


ROOT = Path(__file__).resolve().parents[2]
CODE_CHARS = 80             # a monospace line of the article at 1280 px (measured: 81 scrolls)
TABLE_PX = 688 + 32         # the article, and the wrapper's reach into its margins
CHAR_PX, CELL_PX, TABLE_EXTRA_PX = 6.4, 16.0, 34.0
PRE = re.compile(r'<pre[^>]*>(.*?)</pre>', re.S)
TABLE = re.compile(r'<table>(.*?)</table>', re.S)
ROW = re.compile(r'<tr>(.*?)</tr>', re.S)
CELL = re.compile(r'<t[hd][^>]*>(.*?)</t[hd]>', re.S)
PARAGRAPH = re.compile(r'<p>(.*?)</p>', re.S)
LINK = re.compile(r'<a [^>]*>(.*?)</a>', re.S)
LIST_LINE = re.compile(r'\n\s*(?:[-*+]|\d+\.)\s+\S')
PATH_TEXT = re.compile(r'(?:docs/)?[\w./-]+\.(?:md|html)')


def text_of(fragment):
    """Return the text of an HTML fragment (tags dropped, entities decoded)."""
    return html.unescape(re.sub(r'<[^>]+>', '', fragment))


def pages(site_dir):
    """Return every built page but the 404 page: its name, and its HTML."""
    return {str(p.relative_to(site_dir)): p.read_text() for p in sorted(site_dir.rglob('*.html'))
            if p.name != '404.html'}


def too_long_code_lines(page):
    """Return the lines of a page's code blocks beyond CODE_CHARS (output blocks wrap)."""
    out = []
    for block in PRE.findall(page):
        if 'language-text' in block[:200]:
            continue
        out += [line for line in text_of(block).split('\n') if len(line) > CODE_CHARS]
    return out


def cell_px(cell, first_column):
    """Return the narrowest a cell can be: its longest unbreakable word, and its margins."""
    longest = 0
    for part in re.split(r'(<code>.*?</code>)', cell, flags=re.S):
        text = text_of(part)
        if part.startswith('<code>'):
            words = [text] if first_column else text.split()      # extra.css: nowrap there
        else:
            words = [w for word in text.split() for w in re.split(r'(?<=-)', word)]
        longest = max([longest] + [len(w) for w in words])
    return longest * CHAR_PX + CELL_PX


def table_px(table):
    """Return the estimated width (px) of a rendered table at its narrowest."""
    widths = {}
    for row in ROW.findall(table):
        for j, cell in enumerate(CELL.findall(row)):
            widths[j] = max(widths.get(j, 0.0), cell_px(cell, j == 0))
    return sum(widths.values()) + TABLE_EXTRA_PX


def test_the_estimates_tell_wide_from_narrow():
    narrow = '<table><tr><th>a</th><th>b</th></tr><tr><td>1</td><td>two words</td></tr></table>'
    wide = ('<table><tr>' + '<th>persistence</th>' * 9 + '</tr></table>')
    assert table_px(narrow) < TABLE_PX < table_px(wide)
    assert cell_px('<code>a-b c</code>', True) > cell_px('<code>a-b c</code>', False)
    assert too_long_code_lines('<pre><code>' + 'x' * 81 + '</code></pre>')
    assert not too_long_code_lines('<pre><code class="language-text">' + 'x' * 81 +
                                   '</code></pre>')


def test_no_list_runs_into_the_paragraph_before_it(site):
    found = [f'{name}: {text_of(p)[:60]!r}' for name, page in pages(site).items()
             for p in PARAGRAPH.findall(page) if LIST_LINE.search(p)]
    assert not found, 'a list needs a blank line before it:\n' + '\n'.join(found)


def test_no_code_block_is_wider_than_the_page(site):
    found = [f'{name}: {len(line)} characters: {line[:50]!r}'
             for name, page in pages(site).items() for line in too_long_code_lines(page)]
    assert not found, f'code lines beyond {CODE_CHARS} characters:\n' + '\n'.join(found)


def test_no_table_is_wider_than_the_page(site):
    found = [f'{name}: table {k + 1}, about {table_px(t):.0f} px ({text_of(t).split()[:4]})'
             for name, page in pages(site).items()
             for k, t in enumerate(TABLE.findall(page)) if table_px(t) > TABLE_PX]
    assert not found, f'tables wider than {TABLE_PX} px at 1280:\n' + '\n'.join(found)


def test_link_texts_are_words_not_repository_paths(site):
    found = [f'{name}: {text_of(a)!r}' for name, page in pages(site).items()
             for a in LINK.findall(page) if PATH_TEXT.fullmatch(text_of(a).strip())]
    assert not found, '\n'.join(found)


def test_search_works_from_disk(site):
    """
    From file:// the theme searches an index built into a script, in a worker it cannot start.

    Every page loads the site's own worker for disk (``javascripts/file_worker.js``)
    and nothing from the web; ``tools/site_check.py`` searches in Chromium.
    """
    assert (site / 'search' / 'search_index.js').stat().st_size > 10000
    assert (site / 'javascripts' / 'file_worker.js').is_file()
    for name, page in pages(site).items():
        depth = name.count('/')
        assert f'<script src="{"../" * depth}javascripts/file_worker.js"></script>' in page, name
        assert not re.search(r'<script src="https?:', page), name


@pytest.mark.parametrize('page', ['index.html', 'node.html', 'reference/api.html'])
def test_a_long_reference_has_a_table_of_contents(site, page):
    text = (site / page).read_text()
    toc = text[text.index('md-nav--secondary'):]
    toc = toc[:toc.index('</nav>')]
    assert toc.count('class="md-nav__link"') >= 4, page


def test_every_long_page_has_headings_for_its_table_of_contents():
    """A page of more than 700 words has sections (the glossary is a list of terms)."""
    found = []
    for page in sorted((ROOT / 'docs').rglob('*.md')):
        name = str(page.relative_to(ROOT / 'docs'))
        if name.startswith('decisions/') or name == 'glossary.md':
            continue
        text = page.read_text()
        words = len(re.sub(r'```.*?```', '', text, flags=re.S).split())
        if words > 700 and len(re.findall(r'^##+ ', text, re.M)) < 2:
            found.append(f'{name}: {words} words')
    assert not found, 'long pages without sections:\n' + '\n'.join(found)

"""The evidence page opens with its summary, rendered from its JSON and its template."""

from pathlib import Path
import sys

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / 'tools'))

import evidence_summary  # noqa: E402


@pytest.mark.parametrize('name', sorted(evidence_summary.PAGES))
def test_an_evidence_page_opens_with_its_current_summary(name):
    page = (ROOT / 'docs' / name).read_text()
    folder, make = evidence_summary.PAGES[name]
    block = make(ROOT / 'docs' / folder)
    assert block in page, f'the summary of {name} is stale: run python tools/evidence_summary.py'
    title_end = page.index('\n')
    assert page.index(block) == title_end + 2, 'the summary comes right under the title'
    assert block.count('\n| ') >= 4, 'a header and a row per recording or set'


def test_the_generalisation_summary_has_a_row_per_set():
    block = evidence_summary.render(ROOT / 'docs' / 'generalisation')
    sets = list(evidence_summary.sets(ROOT / 'docs' / 'generalisation'))
    assert len(sets) >= 4
    assert block.count('\n| ') == len(sets) + 1     # the header and a row per set


def test_the_summary_replaces_itself():
    page = '# Title\n\nText.\n'
    once = evidence_summary.with_summary(page, '<!-- summary -->\nA\n<!-- /summary -->\n')
    twice = evidence_summary.with_summary(once, '<!-- summary -->\nB\n<!-- /summary -->\n')
    assert twice == '# Title\n\n<!-- summary -->\nB\n<!-- /summary -->\n\nText.\n'

"""The evidence page opens with its summary, rendered from its JSON and its template."""

from pathlib import Path
import sys

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / 'tools'))

import evidence_summary  # noqa: E402


def test_the_generalisation_page_opens_with_its_current_summary():
    page = (ROOT / 'docs' / 'generalisation.md').read_text()
    block = evidence_summary.render(ROOT / 'docs' / 'generalisation')
    assert block in page, 'the summary is stale: run python tools/evidence_summary.py'
    assert page.index(block) < page.index('\n## ', page.index(block) + len(block)), \
        'the summary comes first'
    # one row per judged set, the recommended class's own verdict in each
    sets = list(evidence_summary.sets(ROOT / 'docs' / 'generalisation'))
    assert len(sets) >= 4
    assert block.count('\n| ') == len(sets) + 1     # the header and a row per set


def test_the_summary_replaces_itself():
    page = '# Title\n\nText.\n'
    once = evidence_summary.with_summary(page, '<!-- summary -->\nA\n<!-- /summary -->\n')
    twice = evidence_summary.with_summary(once, '<!-- summary -->\nB\n<!-- /summary -->\n')
    assert twice == '# Title\n\n<!-- summary -->\nB\n<!-- /summary -->\n\nText.\n'

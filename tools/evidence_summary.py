"""
Open an evidence page with a short table of what holds and what does not.

The table's figures come from the JSON the page's generator wrote beside it
(``docs/generalisation/*.json``); its words from the template
``tools/templates/generalisation_summary.md``, which a writer edits. The
block sits between ``<!-- summary -->`` and ``<!-- /summary -->`` under the
page's title; ``make generalisation`` runs this after writing the page, and
``test/lint/test_evidence_summary.py`` fails while the block is stale.
"""

import argparse
import json
from pathlib import Path
import re
import sys

from generalisation_text import LABELS

ROOT = Path(__file__).resolve().parents[1]
TEMPLATE = Path(__file__).with_name('templates') / 'generalisation_summary.md'
BLOCK = re.compile(r'<!-- summary -->\n.*?<!-- /summary -->\n', re.S)
#: Below this percentile among its own traces, a class is unlike them (5 %).
UNLIKE = 5.0


def sets(json_dir):
    """Yield (name, folds, summary) of every judged set, in file order."""
    for path in sorted(Path(json_dir).glob('*.json')):
        doc = json.loads(path.read_text())
        if isinstance(doc, dict) and 'summary' in doc and doc['folds']:
            yield doc['set'], len(doc['folds']), doc['summary']


def row(name, folds, summary):
    """Return one table row, and whether the population class is unlike its own traces."""
    best = min(summary, key=lambda c: summary[c]['heldout_nll_per_sample'])
    pop = summary['population']
    worst = pop['worst_group']
    own = pop.get('own', {}).get('percentile')
    unlike = own is not None and own < UNLIKE
    said = 'n/a' if own is None else f'{"yes" if unlike else "no"} ({own:.0f} %)'
    return (f'| {name} | {folds} | {LABELS[best]} ({summary[best]["heldout_nll_per_sample"]:.3f}) '
            f'| {pop["heldout_nll_per_sample"]:.3f}, {pop["best_score_folds"]} of {folds} '
            f'| {worst["group"]}, {worst["inside_95"]:.0%} inside | {said} |'), unlike


def render(json_dir):
    """Return the summary block of docs/generalisation.md."""
    rows, unlike = [], []
    for name, folds, summary in sets(json_dir):
        text, bad = row(name, folds, summary)
        rows.append(text)
        if bad:
            unlike.append(name)
    verdict = ('On every set the population class is not unlike its own simulated traces.'
               if not unlike else
               'The population class is unlike its own simulated traces on: '
               + ', '.join(unlike) + '.')
    body = TEMPLATE.read_text().replace('{{ROWS}}', '\n'.join(rows)).replace(
        '{{VERDICT}}', verdict)
    return '<!-- summary -->\n' + body.rstrip('\n') + '\n<!-- /summary -->\n'


def with_summary(page, block):
    """Return ``page`` with ``block`` under its title (replacing an older one)."""
    if BLOCK.search(page):
        return BLOCK.sub(lambda _: block, page, count=1)
    title, _, rest = page.partition('\n')
    return f'{title}\n\n{block}{rest}'


def main(argv=None):
    """Write the summary into docs/generalisation.md; exit 0."""
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--docs', type=Path, default=ROOT / 'docs')
    args = ap.parse_args(argv)
    page = args.docs / 'generalisation.md'
    page.write_text(with_summary(page.read_text(),
                                 render(args.docs / 'generalisation')))
    print(f'wrote the summary of {page}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

"""
Open the evidence pages with a short table of what holds and what does not.

Each table's figures come from the JSON the page's generator wrote beside
it (``docs/generalisation/``, ``docs/calibration/``,
``docs/close-the-loop/``); its words from a template in
``tools/templates/``, which a writer edits. The block sits between
``<!-- summary -->`` and ``<!-- /summary -->`` under the page's title; the
``make`` target of each page runs this after writing it, and
``test/lint/test_evidence_summary.py`` fails while a block is stale.
"""

import argparse
import json
from pathlib import Path
import re
import sys

from generalisation_text import LABELS
from page_template import Template

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r'<!-- summary -->\n.*?<!-- /summary -->\n', re.S)
#: Below this percentile among its own traces, a class is unlike them (5 %).
UNLIKE = 5.0
#: A share of measures inside their envelopes this far below 0.95 is named as a miss.
LOW_SHARE = 0.8


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
    words = Template('generalisation_summary')
    verdict = words.snippet('some-unlike', sets=', '.join(unlike)) if unlike else \
        words.snippet('all-alike')
    return _block(words, rows, verdict)


def _shares(check, key):
    """Return 'N / E' shares of ``key`` in a validation record, and the axes below LOW_SHARE."""
    values = [check[ax][key] for ax in ('north', 'east')]
    low = [ax for ax, v in zip(('north', 'east'), values) if v < LOW_SHARE]
    return f'{values[0]:.0%} / {values[1]:.0%}', low


def render_calibration(json_dir):
    """Return the summary block of docs/calibration.md."""
    rows, misses = [], []
    for path in sorted(Path(json_dir).glob('*.json')):
        doc = json.loads(path.read_text())
        cells = []
        for part, check in (('in sample', doc['pacf'].get('insample')),
                            ('held out', doc.get('holdout', {}).get('pacf'))):
            for key, what in (('acf_lags_inside_envelope', 'ACF'),
                              ('quantiles_inside_envelope', 'quantiles')):
                if check is None:
                    cells.append('too short')
                    continue
                text, low = _shares(check, key)
                cells.append(text)
                misses += [f'{doc["trace"]} {part}, {what} {ax}' for ax in low]
        rows.append(f'| {doc["trace"]} | {doc["rows"]} | ' + ' | '.join(cells) + ' |')
    words = Template('calibration_summary')
    verdict = words.snippet('some-miss', misses='; '.join(misses)) if misses else \
        words.snippet('all-hold')
    return _block(words, rows, verdict)


def render_close_loop(json_dir):
    """Return the summary block of docs/close-the-loop.md."""
    rows, weak = [], []
    for path in sorted(Path(json_dir).glob('*.json')):
        if path.name == 'records.json':         # the synthetic walks and the refusals
            continue
        dg = json.loads(path.read_text())['diagnosis']
        found = [e['name'] for e in dg['effects']] or ['none']
        kept = dg['selection'].get('kept') or ['none']
        gain = dg['improvement']
        lo, hi = gain['ci95']
        if lo <= 0:
            weak.append(dg['input'])
        left = '; '.join(u['structure'] for u in dg['unexplained']) or 'nothing'
        rows.append(f'| {dg["input"]} | {", ".join(found)} | {", ".join(kept)} | '
                    f'{gain["heldout_nll_per_sample"]:.3f} ({lo:.3f} to {hi:.3f}) | {left} |')
    words = Template('close_loop_summary')
    verdict = words.snippet('some-unresolved', names=', '.join(weak)) if weak else \
        words.snippet('all-resolved')
    records = Path(json_dir) / 'records.json'
    refused = sorted(json.loads(records.read_text()).get('refused', {})) \
        if records.is_file() else []
    if refused:
        verdict += '\n\n' + words.snippet('refused', names=', '.join(refused))
    return _block(words, rows, verdict)


def _block(words, rows, verdict):
    """Return a summary block from its template's words, its rows and its verdict."""
    body = words.page(rows='\n'.join(rows), verdict=verdict)
    return '<!-- summary -->\n' + body.strip('\n') + '\n<!-- /summary -->\n'


#: Each evidence page: its file, the folder of its JSON, and its renderer.
PAGES = {'generalisation.md': ('generalisation', render),
         'calibration.md': ('calibration', render_calibration),
         'close-the-loop.md': ('close-the-loop', render_close_loop)}


def with_summary(page, block):
    """Return ``page`` with ``block`` under its title (replacing an older one)."""
    if BLOCK.search(page):
        return BLOCK.sub(lambda _: block, page, count=1)
    title, _, rest = page.partition('\n')
    return f'{title}\n\n{block}{rest}'


def main(argv=None):
    """Write the summaries into the evidence pages (or those named); exit 0."""
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--docs', type=Path, default=ROOT / 'docs')
    ap.add_argument('pages', nargs='*', default=sorted(PAGES), help='pages to update')
    args = ap.parse_args(argv)
    for name in args.pages:
        folder, make = PAGES[name]
        page = args.docs / name
        page.write_text(with_summary(page.read_text(), make(args.docs / folder)))
        print(f'wrote the summary of {page}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

"""docs/walks.md is its template filled in from data/, and opens with what holds."""

from pathlib import Path
import re
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[2]


def _without_date(text):
    """Return the page without the paragraph that says when and where it was made."""
    return re.sub(r'Measured on .*?\n\n', '', text, flags=re.S)


def test_make_walks_profile_writes_the_shipped_page_and_profile(tmp_path):
    (tmp_path / 'docs').mkdir()
    (tmp_path / 'config' / 'profiles').mkdir(parents=True)
    subprocess.run([sys.executable, str(ROOT / 'tools' / 'walks_profile.py'),
                    '--data', str(ROOT / 'data'), '--out', str(tmp_path)],
                   check=True, capture_output=True, cwd=ROOT)
    built = (tmp_path / 'docs' / 'walks.md').read_text()
    shipped = (ROOT / 'docs' / 'walks.md').read_text()
    assert _without_date(built) == _without_date(shipped), \
        'docs/walks.md differs from tools/templates/walks.md and data/: run make walks-profile'
    name = 'snapshot-receiver-on-foot.yaml'
    assert (tmp_path / 'config' / 'profiles' / name).read_text() == \
        (ROOT / 'config' / 'profiles' / name).read_text()
    # the summary comes right under the title, a row per walk
    head = shipped.split('\n## ')[1]
    assert head.startswith('In short: what holds and what does not')
    assert head.count('\n| snapper-walk-') == len(list((ROOT / 'data').glob('snapper-walk-*.csv')))

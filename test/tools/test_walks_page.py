"""docs/walks.md is its template filled in from data/, and opens with what holds."""

from pathlib import Path
import re
import subprocess
import sys

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]


def _without_date(text):
    """Return the page without the paragraph that says when and where it was made."""
    return re.sub(r'Measured on .*?\n\n', '', text, flags=re.S)


def _same(built, shipped, where='profile'):
    """
    Assert two profiles' plain data equal: text exactly, numbers to 1e-6 relative.

    The gross failures' rate per agent comes out of an optimiser (L-BFGS-B),
    whose last digits move with the processor's BLAS kernels.
    """
    if isinstance(shipped, dict):
        assert isinstance(built, dict) and built.keys() == shipped.keys(), where
        for k in shipped:
            _same(built[k], shipped[k], f'{where}.{k}')
    elif isinstance(shipped, list):
        assert isinstance(built, list) and len(built) == len(shipped), where
        for i, (a, b) in enumerate(zip(built, shipped)):
            _same(a, b, f'{where}[{i}]')
    elif isinstance(shipped, float):
        assert built == pytest.approx(shipped, rel=1e-6, abs=1e-9), where
    else:
        assert built == shipped, where


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
    _same(yaml.safe_load((tmp_path / 'config' / 'profiles' / name).read_text()),
          yaml.safe_load((ROOT / 'config' / 'profiles' / name).read_text()))
    # the summary comes right under the title, a row per walk
    head = shipped.split('\n## ')[1]
    assert head.startswith('In short: what holds and what does not')
    assert head.count('\n| snapper-walk-') == len(list((ROOT / 'data').glob('snapper-walk-*.csv')))

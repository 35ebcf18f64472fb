"""docs/model.md is what tools/model_page.py writes from the repository's data today."""

from pathlib import Path
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[2]


def _body(text):
    """Return a page without its last line (the date and machine it was measured on)."""
    return text.rstrip('\n').rsplit('\n', 1)[0]


def test_the_model_page_is_its_generators_output(tmp_path):
    (tmp_path / 'docs' / 'images').mkdir(parents=True)
    r = subprocess.run([sys.executable, str(ROOT / 'tools' / 'model_page.py'), '--data',
                        str(ROOT / 'data'), '--out', str(tmp_path)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    page = (tmp_path / 'docs' / 'model.md').read_text()
    assert _body(page) == _body((ROOT / 'docs' / 'model.md').read_text()), \
        'docs/model.md is stale: run make model-page'
    png = (tmp_path / 'docs' / 'images' / 'real-vs-simulated.png').read_bytes()
    assert png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 50_000
    # the figures the issue names: DS5 about 10 m RMS per axis, the car phone about 1.3 m
    ds5 = next(line for line in page.splitlines() if line.startswith('| `DS5`'))
    car = next(line for line in page.splitlines() if line.startswith('| `phone-suburban'))
    assert ds5.split('|')[2].strip().startswith(('9.', '10.'))
    assert car.split('|')[2].strip().startswith('1.')

"""The Python block of ``docs/p2v.md`` runs as written, in real ns-3 (a process of its own)."""

from pathlib import Path
import re
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[2]


def test_the_pages_example_runs(tmp_path):
    """The page's GpsSource example prints a fix with a position and an accuracy."""
    blocks = re.findall(r'```python\n(.*?)```', (ROOT / 'docs' / 'p2v.md').read_text(), re.S)
    assert blocks, 'docs/p2v.md shows the source in Python'
    script = tmp_path / 'example.py'
    script.write_text(blocks[0])
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=600, cwd=ROOT)
    assert run.returncode == 0, run.stderr[-3000:]
    assert "'fix': 1.0" in run.stdout and "'accuracy':" in run.stdout, run.stdout

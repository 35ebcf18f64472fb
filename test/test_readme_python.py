"""The README's Python blocks run as written, from the repository's root."""

from pathlib import Path
import re

ROOT = Path(__file__).resolve().parents[1]


def test_the_readme_python_runs(monkeypatch, capsys):
    blocks = re.findall(r'```python\n(.*?)```', (ROOT / 'README.md').read_text(), re.S)
    assert blocks, 'the README shows the package in Python'
    monkeypatch.chdir(ROOT)
    for block in blocks:
        exec(compile(block, 'README.md', 'exec'), {})
    out = capsys.readouterr().out
    assert '(100, 3600, 2)' in out, out

"""
The tutorials (and the how-tos that run alone) run as written: every block, and its output.

A page's ``python`` blocks run in one namespace (a block that starts
``# file: NAME`` is saved as that file instead), its ``bash`` blocks in
bash, all in a fresh folder that holds the repository's ``data/`` (as a
user's root does) with the package's commands on the PATH (``make setup``
and ``. .venv/bin/activate``, which the pages ask for first, are what
``make test`` has done). A ``text`` block right after a code block is its
output: each line must come, in order, where a line ``...`` stands for any
number of lines and ``...`` inside a line for any text.
"""

import contextlib
import io
import os
from pathlib import Path
import re
import subprocess
import sys

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = ['tutorials/python.md', 'tutorials/calibrate.md', 'tutorials/node.md',
         'tutorials/sumo.md', 'gross-failures.md', 'bags.md', 'outages.md',
         'reported-accuracy.md', 'reference/api.md']
BLOCK = re.compile(r'```(\w+)\n(.*?)```', re.S)


def steps(page):
    """Return [(language, code, expected output or None)] of a tutorial page, in order."""
    found = [(m.group(1), m.group(2), m.end(), m.start()) for m in BLOCK.finditer(page)]
    out = []
    for i, (lang, code, end, _) in enumerate(found):
        if lang == 'text':
            continue
        nxt = found[i + 1] if i + 1 < len(found) else None
        expected = nxt[1] if nxt and nxt[0] == 'text' and not page[end:nxt[3]].strip() \
            else None
        out.append((lang, code, expected))
    return out


def matches(expected, got):
    """Return whether ``got`` shows every line of ``expected`` in order ('...': any lines)."""
    want = expected.rstrip('\n').split('\n')
    lines = [line.rstrip() for line in got.rstrip('\n').split('\n')]

    def match(i, j):
        if i == len(want):
            return j == len(lines)
        if want[i] == '...':
            return any(match(i + 1, k) for k in range(j, len(lines) + 1))
        return j < len(lines) and same(want[i].rstrip(), lines[j]) and match(i + 1, j + 1)
    return match(0, 0)


def same(want, line):
    """Return whether ``line`` is ``want``, where ``...`` inside it stands for any text."""
    if '...' not in want:
        return line == want
    return re.fullmatch('.*'.join(map(re.escape, want.split('...'))), line) is not None


def test_the_matcher_takes_ellipses_and_order():
    assert matches('a\n...\nc\n', 'a\nb\nb\nc\n')
    assert not matches('a\nc\n', 'a\nb\nc\n')
    assert not matches('c\n...\na\n', 'a\nb\nc\n')
    assert matches('wrote .../x.xml (3)\n', 'wrote /tmp/a/b/x.xml (3)\n')
    assert not matches('wrote .../x.xml (3)\n', 'wrote /tmp/a/b/x.xml (4)\n')


@pytest.mark.parametrize('name', PAGES)
def test_a_tutorial_runs_as_written(name, tmp_path, monkeypatch):
    page = (ROOT / 'docs' / name).read_text()
    (tmp_path / 'data').symlink_to(ROOT / 'data')
    monkeypatch.chdir(tmp_path)
    env = dict(os.environ, PATH=f'{Path(sys.executable).parent}{os.pathsep}{os.environ["PATH"]}')
    namespace = {}
    ran = 0
    for lang, code, expected in steps(page):
        first = code.split('\n', 1)[0]
        if lang == 'python' and first.startswith('# file: '):
            (tmp_path / first[len('# file: '):].strip()).write_text(code)
            ran += 1
            continue
        if lang == 'python':
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                exec(compile(code, name, 'exec'), namespace)
            got = out.getvalue()
        elif lang == 'bash':
            res = subprocess.run(['bash', '-e', '-c', code], cwd=tmp_path, env=env,
                                 capture_output=True, text=True, timeout=600)
            assert res.returncode == 0, (code, res.stdout, res.stderr)
            got = res.stdout
        else:
            continue
        ran += 1
        if expected is not None:
            assert matches(expected, got), f'{name}: {code}\nexpected:\n{expected}\ngot:\n{got}'
    assert ran >= 2, f'{name}: only {ran} steps'

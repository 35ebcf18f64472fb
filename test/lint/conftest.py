"""Fixtures of the lint tests: the documentation site, built once for all of them."""

import os
from pathlib import Path
import subprocess
import sys

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope='session')
def site(tmp_path_factory):
    """Build the site strictly into a folder of its own; return the folder."""
    out = tmp_path_factory.mktemp('site')
    subprocess.run([sys.executable, str(ROOT / 'tools' / 'docs_index.py')], check=True,
                   capture_output=True)
    env = dict(os.environ, NO_MKDOCS_2_WARNING='1')
    run = subprocess.run([sys.executable, '-m', 'mkdocs', 'build', '--strict', '--site-dir',
                          str(out)], cwd=ROOT, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    assert 'WARNING' not in run.stderr, run.stderr
    return out

"""The documentation site builds strictly: no broken link, no page outside the navigation."""

import os
from pathlib import Path
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[2]


def test_mkdocs_builds_the_site_strictly(tmp_path):
    subprocess.run([sys.executable, str(ROOT / 'tools' / 'docs_index.py')], check=True,
                   capture_output=True)
    env = dict(os.environ, NO_MKDOCS_2_WARNING='1')
    run = subprocess.run([sys.executable, '-m', 'mkdocs', 'build', '--strict', '--site-dir',
                          str(tmp_path / 'site')], cwd=ROOT, env=env, capture_output=True,
                         text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    assert 'WARNING' not in run.stderr, run.stderr
    home = (tmp_path / 'site' / 'index.html').read_text()
    assert 'gps_error_ros' in home
    api = (tmp_path / 'site' / 'reference' / 'api' / 'index.html').read_text()
    assert 'load_profile' in api and 'WithPopulation' in api

"""docs/reference/commands.md is every command's own ``--help``."""

from pathlib import Path
import sys

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / 'tools'))

import commands_doc  # noqa: E402


def test_the_commands_page_is_the_parsers_help():
    page = (ROOT / 'docs' / 'reference' / 'commands.md').read_text()
    assert page == commands_doc.render(), \
        'docs/reference/commands.md is stale: run python tools/commands_doc.py'
    for name in ('calibrate', 'validate', 'simulate', 'diagnose', 'compare', 'import',
                 'synth', 'scenario'):
        assert f'## `gps_error {name}`' in page
    assert '--population' in page and '--folds' in page

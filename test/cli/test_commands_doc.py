"""docs/reference/commands*.md are every command's own ``--help``."""

from pathlib import Path
import sys

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / 'tools'))

import commands_doc  # noqa: E402


def test_the_commands_page_is_the_parsers_help():
    pages = commands_doc.render()
    for name, text in pages.items():
        assert (ROOT / 'docs' / 'reference' / name).read_text() == text, \
            f'docs/reference/{name} is stale: run python tools/commands_doc.py'
    page = '\n'.join(pages.values())
    for name in ('calibrate', 'validate', 'simulate', 'diagnose', 'compare', 'import',
                 'synth', 'scenario'):
        assert f'## `gps_error {name}`' in page
    assert '--population' in page and '--folds' in page

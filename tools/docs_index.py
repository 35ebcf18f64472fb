"""
Write docs/index.md, the site's home page, from README.md.

The README is the one text; the site shows it with its links made relative
to ``docs/`` (``docs/node.md`` becomes ``node.md``). ``make docs`` and the
docs test run this before ``mkdocs build --strict``; docs/index.md is not
kept in git.
"""

from pathlib import Path
import re
import sys

ROOT = Path(__file__).resolve().parents[1]


def render(readme):
    """Return the home page's text from the README's."""
    return re.sub(r'\]\(docs/', '](', readme)


def main():
    """Write docs/index.md; exit 0."""
    out = ROOT / 'docs' / 'index.md'
    out.write_text(render((ROOT / 'README.md').read_text()))
    print(f'wrote {out}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

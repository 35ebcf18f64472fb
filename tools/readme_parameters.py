"""
Rewrite the parameter tables in README.md from the nodes' parameter table.

Run ``python tools/readme_parameters.py`` after changing
``gps_error_ros/ros/parameters.py``; ``test/ros/test_parameters_doc.py``
fails while the README and the table disagree. Each table sits between
``<!-- parameters:NODE -->`` and ``<!-- /parameters:NODE -->``.
"""

from pathlib import Path
import re
import sys

from gps_error_ros.ros.parameters import markdown_table, README_TABLES

README = Path(__file__).resolve().parents[1] / 'README.md'


def render(text):
    """Return ``text`` with every marked table regenerated."""
    for node, specs in README_TABLES.items():
        pattern = re.compile(rf'(<!-- parameters:{node} -->\n).*?(<!-- /parameters:{node} -->)',
                             re.S)
        if not pattern.search(text):
            raise SystemExit(f'README.md: no <!-- parameters:{node} --> block')
        text = pattern.sub(lambda m: m.group(1) + markdown_table(specs) + m.group(2),
                           text)
    return text


def main():
    """Rewrite README.md in place; exit 0."""
    README.write_text(render(README.read_text()))
    print(f'wrote {README}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

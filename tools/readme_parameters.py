"""
Rewrite the README's parameter tables and config/<node>.yaml from the table.

Run ``python tools/readme_parameters.py`` after changing
``gps_error_ros/ros/parameters.py``; ``test/ros/test_parameters_doc.py``
fails while the README or the parameters files and the table disagree. Each
README table sits between ``<!-- parameters:NODE -->`` and
``<!-- /parameters:NODE -->``.
"""

from pathlib import Path
import re
import sys

from gps_error_ros.ros.parameters import markdown_table, params_file, README_TABLES

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
    """Rewrite README.md in place and the parameters files; exit 0."""
    README.write_text(render(README.read_text()))
    print(f'wrote {README}')
    for node, specs in README_TABLES.items():
        path = README.parent / 'config' / f'{node}.yaml'
        path.write_text(params_file(node, specs))
        print(f'wrote {path}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

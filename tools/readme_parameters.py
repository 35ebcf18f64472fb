"""
Rewrite the README's parameter and topic tables and config/<node>.yaml.

Run ``python tools/readme_parameters.py`` after changing
``gps_error_ros/ros/parameters.py`` or ``gps_error_ros/ros/topics.py``;
``test/ros/test_parameters_doc.py`` fails while the README or the parameters
files and the tables disagree. Each README table sits between
``<!-- parameters:NODE -->`` and ``<!-- /parameters:NODE -->`` (topics:
``<!-- topics:NODE -->``).
"""

from pathlib import Path
import re
import sys

from gps_error_ros.ros.parameters import markdown_table, params_file, README_TABLES
from gps_error_ros.ros.topics import markdown_topics

README = Path(__file__).resolve().parents[1] / 'README.md'


def render(text):
    """Return ``text`` with every marked table regenerated."""
    for node, specs in README_TABLES.items():
        for kind, table in (('parameters', markdown_table(specs)),
                            ('topics', markdown_topics(node))):
            pattern = re.compile(rf'(<!-- {kind}:{node} -->\n).*?(<!-- /{kind}:{node} -->)',
                                 re.S)
            if not pattern.search(text):
                raise SystemExit(f'README.md: no <!-- {kind}:{node} --> block')
            text = pattern.sub(lambda m, t=table: m.group(1) + t + m.group(2), text)
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

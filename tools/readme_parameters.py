"""
Rewrite the docs' parameter, topic and effect tables and config/<node>.yaml.

Run ``python tools/readme_parameters.py`` after changing
``gps_error_ros/ros/parameters.py`` or ``gps_error_ros/ros/topics.py``;
``test/ros/test_parameters_doc.py`` fails while a docs page or the parameters
files and the tables disagree. Each table sits in one page of ``docs/``
between ``<!-- parameters:NODE -->`` and ``<!-- /parameters:NODE -->``
(topics: ``<!-- topics:NODE -->``).
"""

from pathlib import Path
import re
import sys

from gps_error_ros.ros.parameter_docs import (markdown_table, params_file, README_GROUPS,
                                              README_TABLES)
from gps_error_ros.model import (availability, failures, population, profiles,
                                 reported, velocity)
from gps_error_ros.model.effect_kinds import keys_table, markdown_table as effects_table
from gps_error_ros.ros.topics import markdown_topics

ROOT = Path(__file__).resolve().parents[1]
#: The profile sections declared field by field, whose tables the docs show.
SECTIONS = {'axes': profiles.AXIS_SECTIONS['north'], 'availability': availability.SECTION,
            'gross_failures': failures.SECTION,
            'population': population.SECTION, 'reported_accuracy': reported.SECTION,
            'velocity': velocity.SECTION}
DOCS = ROOT / 'docs'


def fill(pages, mark, table):
    """Put ``table`` between every page's ``<!-- mark -->`` and ``<!-- /mark -->``; none: exit."""
    pattern = re.compile(rf'(<!-- {mark} -->\n).*?(<!-- /{mark} -->)', re.S)
    found = [p for p, text in pages.items() if pattern.search(text)]
    if not found:
        raise SystemExit(f'docs/: no page has a <!-- {mark} --> block')
    for p in found:
        pages[p] = pattern.sub(lambda m: m.group(1) + table + m.group(2), pages[p])


def render(pages):
    """Return {page: text} with every marked table regenerated where its markers are."""
    for node, specs in README_TABLES.items():
        groups = README_GROUPS.get(node, ())
        fill(pages, f'parameters:{node}', markdown_table(specs, groups))
        fill(pages, f'topics:{node}', markdown_topics(node))
    for name, spec in SECTIONS.items():
        fill(pages, f'section:{name}', spec.markdown())
    fill(pages, 'effects:table', effects_table())
    fill(pages, 'effects:keys', keys_table())
    return pages


def main():
    """Rewrite the docs pages' tables in place and the parameters files; exit 0."""
    pages = {p: p.read_text() for p in sorted(DOCS.glob('*.md'))}
    for page, text in render(dict(pages)).items():
        if text != pages[page]:
            page.write_text(text)
            print(f'wrote {page}')
    for node, specs in README_TABLES.items():
        path = ROOT / 'config' / f'{node}.yaml'
        path.write_text(params_file(node, specs))
        print(f'wrote {path}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

"""A profile section declared once (``model/section_spec.py``): read, written, documented."""

from pathlib import Path
import re

import pytest

from gps_error_ros.model import availability, failures, population, reported
from gps_error_ros.model.section_spec import Field, SectionSpec

ROOT = Path(__file__).resolve().parents[2]
SPECS = {'availability': availability.SECTION, 'gross_failures': failures.SECTION,
         'population': population.SECTION, 'reported_accuracy': reported.SECTION}
TOY = SectionSpec('toy', (
    Field('rate', 'a rate', lo=0.0, hi=1.0, hi_open=True, digits=3),
    Field('sizes', 'sizes', kind='sizes', lo=0.0, hi=1e9, lo_open=True),
    Field('mode', 'a mode', kind='choice', choices=('a', 'b')),
    Field('dof', 'an integer', kind='integer', lo=3, hi=30, absent='normal'),
    Field('lengths', 'a law', kind='distribution', lo=1, absent='none', digits=2),
), ValueError)


@pytest.mark.parametrize('raw, says', [
    ({'rate': 0.5, 'sizes': [1.0], 'mode': 'a', 'x': 1},
     r"key 'toy': expected a mapping with \['rate', 'sizes', 'mode'\] and optionally "
     r"\['dof', 'lengths'\] \(toy.x is not a key of it\)"),
    ({'sizes': [1.0], 'mode': 'a'}, r"\(toy.rate is missing\)"),
    ({'rate': 1.0, 'sizes': [1.0], 'mode': 'a'}, r'toy.rate: expected a number in \[0, 1\)'),
    ({'rate': True, 'sizes': [1.0], 'mode': 'a'}, 'toy.rate: expected a number'),
    ({'rate': 0.5, 'sizes': [2.0, 1.0], 'mode': 'a'},
     r'non-decreasing list of numbers in \(0, 1e9\]'),
    ({'rate': 0.5, 'sizes': [], 'mode': 'a'}, 'toy.sizes: expected a non-empty'),
    ({'rate': 0.5, 'sizes': [1.0], 'mode': 'c'},
     r"toy.mode: expected one of \['a', 'b'\], got 'c'"),
    ({'rate': 0.5, 'sizes': [1.0], 'mode': 'a', 'dof': 4.5},
     r'toy.dof: expected an integer in \[3, 30\], or the key left out \(normal\), got 4.5'),
    ({'rate': 0.5, 'sizes': [1.0], 'mode': 'a', 'lengths': [[0, 1.0]]},
     r'toy.lengths: expected a non-empty list of \[value, probability\] pairs \(integer '
     r'values in \[1, inf\]'),
    ({'rate': 0.5, 'sizes': [1.0], 'mode': 'a', 'lengths': [[2, 1.5]]},
     r'probabilities in \(0, 1\]\), or the key left out \(none\), got \[\[2, 1.5\]\]'),
    ({'rate': 0.5, 'sizes': [1.0], 'mode': 'a', 'lengths': [[2.0, 1.0]]}, 'toy.lengths'),
])
def test_a_bad_value_is_named_with_what_was_expected(raw, says):
    with pytest.raises(ValueError, match=says):
        TOY.read(raw, 'here')


def test_values_read_back_as_written():
    values = TOY.read({'rate': 0.12345, 'sizes': [1, 2.5], 'mode': 'b'}, 'here')
    assert values == {'rate': 0.12345, 'sizes': (1.0, 2.5), 'mode': 'b', 'dof': None,
                      'lengths': None}
    assert TOY.write(values) == {'rate': 0.123, 'sizes': [1.0, 2.5], 'mode': 'b'}
    assert TOY.read(TOY.write(values), 'here')['rate'] == 0.123
    law = TOY.read({'rate': 0.5, 'sizes': [1], 'mode': 'a', 'lengths': [[2, 0.333], [5, 1]]},
                   'here')['lengths']
    assert law == ((2, 0.333), (5, 1.0))
    assert TOY.write({'rate': 0.5, 'sizes': [1.0], 'mode': 'a', 'lengths': law})['lengths'] \
        == [[2, 0.33], [5, 1.0]]


@pytest.mark.parametrize('name', sorted(SPECS))
def test_the_docs_tables_are_the_declarations(name):
    pattern = rf'<!-- section:{name} -->\n(.*?)<!-- /section:{name} -->'
    found = [m.group(1) for p in (ROOT / 'docs').glob('*.md')
             for m in [re.search(pattern, p.read_text(), re.S)] if m]
    assert found == [SPECS[name].markdown()], \
        f'the {name} table is stale: run python tools/readme_parameters.py'

"""The README's parameter tables are the nodes' own table, rendered."""

from pathlib import Path
import re

from rcl_interfaces.msg import ParameterType

from gps_error_ros.ros.parameters import (ERROR_NODE_PARAMS, markdown_table,
                                          README_TABLES)

README = Path(__file__).resolve().parents[2] / 'README.md'


def test_readme_tables_match_the_parameter_table():
    text = README.read_text()
    for node, specs in README_TABLES.items():
        m = re.search(rf'<!-- parameters:{node} -->\n(.*?)<!-- /parameters:{node} -->',
                      text, re.S)
        assert m, f'README.md has no table for {node}'
        assert m.group(1) == markdown_table(specs), \
            f'README.md: the {node} table is stale: run python tools/readme_parameters.py'


def test_table_rows_carry_each_descriptor():
    table = markdown_table(ERROR_NODE_PARAMS)
    for spec in ERROR_NODE_PARAMS:
        row = next(r for r in table.splitlines() if r.startswith(f'| `{spec.name}` |'))
        assert spec.description in row
        assert ('| yes |' in row) == spec.read_only
        if spec.type == ParameterType.PARAMETER_DOUBLE and spec.low is not None:
            assert f'{spec.low:g} to {spec.high:g}' in row

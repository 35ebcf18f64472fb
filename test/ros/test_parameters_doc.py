"""The docs' parameter and topic tables are the nodes' own tables, rendered."""

from pathlib import Path
import re

from rcl_interfaces.msg import ParameterType

from gps_error_ros.sim.sumo_scenario import build_grid_scenario
from gps_error_ros.ros.parameter_docs import (markdown_table, params_file, README_GROUPS,
                                              README_TABLES)
from gps_error_ros.ros.parameters import ERROR_NODE_PARAMS
from gps_error_ros.ros.topics import markdown_topics
from ros_harness import NodeProcess, unique_ns

ROOT = Path(__file__).resolve().parents[2]
PAGES = sorted((ROOT / 'docs').glob('*.md'))


def _block(kind, node):
    """Return (page, the text between the ``kind:node`` markers) of the page holding them."""
    pattern = rf'<!-- {kind}:{node} -->\n(.*?)<!-- /{kind}:{node} -->'
    for page in PAGES:
        m = re.search(pattern, page.read_text(), re.S)
        if m:
            return page.name, m.group(1)
    raise AssertionError(f'no docs page has the {kind} table of {node}')


def test_the_docs_tables_match_the_parameter_table():
    for node, specs in README_TABLES.items():
        page, table = _block('parameters', node)
        assert table == markdown_table(specs, README_GROUPS.get(node, ())), \
            f'docs/{page}: the {node} table is stale: run python tools/readme_parameters.py'
        page, table = _block('topics', node)
        assert table == markdown_topics(node), \
            f'docs/{page}: the {node} topic table is stale: run python tools/readme_parameters.py'


def test_grouped_tables_hold_every_parameter_once():
    grouped = markdown_table(ERROR_NODE_PARAMS, README_GROUPS['gps_error_node'])
    rows = [r for r in grouped.splitlines() if r.startswith('| `')]
    assert sorted(rows) == sorted(r for r in markdown_table(ERROR_NODE_PARAMS).splitlines()
                                  if r.startswith('| `'))
    assert grouped.count('\n### ') + grouped.startswith('### ') >= 4
    import pytest
    with pytest.raises(ValueError, match='each once'):
        markdown_table(ERROR_NODE_PARAMS, [('all but one', [s.name for s in
                                                            ERROR_NODE_PARAMS[1:]])])


def test_table_rows_carry_each_descriptor():
    table = markdown_table(ERROR_NODE_PARAMS)
    for spec in ERROR_NODE_PARAMS:
        row = next(r for r in table.splitlines() if r.startswith(f'| `{spec.name}` |'))
        assert spec.description in row
        assert ('read-only' in row) == spec.read_only
        if spec.type == ParameterType.PARAMETER_DOUBLE and spec.low is not None:
            assert f'{spec.low:g} to {spec.high:g}' in row


def test_parameters_files_are_the_table_and_start_the_nodes(tmp_path):
    for node, specs in README_TABLES.items():
        path = ROOT / 'config' / f'{node}.yaml'
        assert path.read_text() == params_file(node, specs), \
            f'{path} is stale: run python tools/readme_parameters.py'
    runs = [('gps_error_node', ['-p', 'datum:=[40.75, -73.99, 0.0]'], 'fixes at 1.0 Hz'),
            ('gps_calibration_node', ['-p', 'datum:=[40.75, -73.99, 0.0]',
                                      '-p', f'output:={tmp_path / "p.yaml"}'],
             'calibrating from')]
    scenario = build_grid_scenario(tmp_path / 'sumo', grid=2, length=50.0, depart_until=4.0)
    runs.append(('gps_error_sumo', ['-p', f'sumocfg:={scenario.sumocfg}', '-p', 'speed:=0.0'],
                 'SUMO ended'))          # runs to SUMO's end at once, and exits 0
    for node, extra, started in runs:
        proc = NodeProcess(['--ros-args', '-r', f'__ns:={unique_ns()}', '--params-file',
                            str(ROOT / 'config' / f'{node}.yaml')] + extra, name=node)
        assert proc.wait_output(started), proc.stop()[1]     # unknown ones are named before
        rc, log = proc.stop()
        assert rc == 0 and started in log and 'unknown parameter' not in log, log

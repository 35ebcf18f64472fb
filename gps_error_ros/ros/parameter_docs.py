"""
The nodes' parameter tables as people read them: ``--help``, the docs' tables, parameters files.

``tools/readme_parameters.py`` writes the docs' tables and ``config/<node>.yaml``
from these; a test keeps them equal to what the nodes declare.
"""

from collections.abc import Sequence

from rcl_interfaces.msg import ParameterType

from gps_error_ros.ros.parameters import (TYPE_NAMES, CALIBRATION_NODE_PARAMS,
                                          ERROR_NODE_PARAMS, INT64_MAX, ParamSpec,
                                          SUMO_NODE_PARAMS)


def _default_text(spec: ParamSpec) -> str:
    if spec.default is None:
        return '`[]`' if spec.type == ParameterType.PARAMETER_STRING_ARRAY else '(none)'
    if isinstance(spec.default, str):
        return f'`{spec.default}`' if spec.default else "`''`"
    return f'`{spec.default!r}`'


def _bounds_text(spec: ParamSpec) -> str:
    if spec.choices:
        return ', '.join(f'`{c}`' for c in spec.choices)
    if spec.low is not None:
        high = 'max' if spec.high == INT64_MAX else f'{spec.high:g}'
        return f'{spec.low:g} to {high}'
    return ''


def markdown_table(specs: Sequence[ParamSpec],
                   groups: Sequence[tuple[str, Sequence[str]]] = ()) -> str:
    """
    Return the Markdown table of a parameter table, for the README.

    The README's tables are this function's output (``tools/readme_parameters.py``
    rewrites them; a test checks that they agree), so that the documentation
    cannot drift from the descriptors the nodes declare. Three columns, so
    that it fits a page of 1280 px: the name, the default, and the meaning
    led by the type, the range or choices and whether the value is fixed at
    start (read-only). With ``groups`` ((heading, names), every parameter in
    one), a table per group under its own heading, so the page has a table
    of contents.
    """
    if groups:
        named = [n for _, names in groups for n in names]
        if sorted(named) != sorted(s.name for s in specs):
            raise ValueError(f'parameter groups {named} are not the parameters '
                             f'{[s.name for s in specs]}, each once')
        by_name = {s.name: s for s in specs}
        return '\n'.join(f'### {title}\n\n' + markdown_table([by_name[n] for n in names])
                         for title, names in groups)
    lines = ['| parameter | default | meaning |', '|---|---|---|']
    for s in specs:
        kind = ', '.join(t for t in (TYPE_NAMES[s.type].split(' ', 1)[1], _bounds_text(s),
                                     'read-only' if s.read_only else 'settable at run time')
                         if t)
        lines.append(f'| `{s.name}` | {_default_text(s)} | *{kind}.* {s.description} |')
    return '\n'.join(lines) + '\n'


#: The error node's parameters under headings, for its page.
ERROR_NODE_GROUPS = (
    ('The model', ('profile', 'seed', 'rate', 'start_time', 'zones')),
    ('The truth it reads', ('input_type', 'datum', 'truth_frame', 'other_frames',
                            'max_pose_age', 'input_reliability')),
    ('What it publishes', ('frame_id', 'covariance_mode', 'covariance_about', 'outage_output',
                           'pose_frame_id', 'fix_reliability', 'nmea_port')),
    ('Faults on demand', ('fault_schedule', 'faults')),
    ('Crowds', ('agents', 'agent_profiles', 'agent_pattern', 'agent_timeout')),
)


#: README markers around each generated table: node name -> parameter table
README_TABLES = {'gps_error_node': ERROR_NODE_PARAMS,
                 'gps_calibration_node': CALIBRATION_NODE_PARAMS,
                 'gps_error_sumo': SUMO_NODE_PARAMS}
#: The nodes whose page lists their parameters under headings.
README_GROUPS = {'gps_error_node': ERROR_NODE_GROUPS}


def help_text(node: str, summary: str, specs: Sequence[ParamSpec],
              topics: Sequence[tuple[str, str, str, str]], example: str) -> str:
    """
    Return what ``NODE --help`` prints: the node, its parameters, topics, an example.

    ``topics`` is a list of (direction, topic, type, note) rows.
    """
    lines = [f'{node}: {summary}', '',
             f'usage: {node} [--help] [--ros-args -p NAME:=VALUE ... '
             f'[--params-file FILE] [-r FROM:=TO ...]]', '', 'parameters:']
    for s in specs:
        bounds = _bounds_text(s).replace('`', '')
        extra = ', '.join(t for t in (
            TYPE_NAMES[s.type], f'default {_default_text(s).strip("`")}',
            bounds and (f'one of {bounds}' if s.choices else f'range {bounds}'),
            'read-only' if s.read_only else 'settable at runtime')
            if t)
        lines.append(f'  {s.name} ({extra})')
        lines.append(f'      {s.description}')
    lines += ['', 'topics:']
    for direction, topic, msg_type, note in topics:
        lines.append(f'  {direction:4} {topic:24} {msg_type}  {note}')
    lines += ['', 'example:', f'  {example}', '']
    return '\n'.join(lines)


def _yaml_value(spec: ParamSpec) -> str:
    v = spec.default
    if isinstance(v, str):
        plain = v and all(c.isalnum() or c in '_./-' for c in v)
        return v if plain else '"' + v.replace('"', '\\"') + '"'
    return repr(v)


def params_file(node: str, specs: Sequence[ParamSpec]) -> str:
    """
    Return a ROS 2 parameters file of ``node``: every parameter at its default.

    Each parameter comes with its description as a comment; those without a
    default (``datum``, the agent lists) are written commented out, with an
    example. ``tools/readme_parameters.py`` writes ``config/<node>.yaml`` from
    this, and a test checks the files agree with the table.
    """
    examples = {'datum': '[40.75057, -73.99065, -23.0]',
                'agent_pattern': '/peds/*/pose',
                'agents': '["ped1", "ped2", "ped3"]',
                'agent_profiles': '["DS2", "DS5", "DS7"]',
                'sumo_args': '["--fcd-output", "fcd.xml"]'}
    lines = [f'# {node}: every parameter at its default (generated from the node\'s',
             '# parameter table by tools/readme_parameters.py; do not edit by hand).',
             f'# Use: {node} --ros-args --params-file config/{node}.yaml',
             '/**:', '  ros__parameters:']
    for s in specs:
        text = s.description + (f' One of: {", ".join(s.choices)}.' if s.choices else '')
        words, line = text.split(), '    #'
        for w in words:
            if len(line) + len(w) > 88:
                lines.append(line)
                line = '    #'
            line += ' ' + w
        lines.append(line)
        if s.default is None:
            lines.append(f'    # {s.name}: {examples.get(s.name, "")}')
        else:
            lines.append(f'    {s.name}: {_yaml_value(s)}')
    return '\n'.join(lines) + '\n'

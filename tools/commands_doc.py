"""
Write docs/reference/commands*.md from ``gps_error --help`` and each command's ``--help``.

The page is the parsers' own help, so it cannot say what the commands do not
do; ``test/cli/test_commands_doc.py`` fails while the page and the parsers
disagree. Run ``python tools/commands_doc.py`` after changing
``gps_error_ros/cli/parser.py``.
"""

import os
from pathlib import Path
import sys

PAGE = Path(__file__).resolve().parents[1] / 'docs' / 'reference' / 'commands.md'
#: The width the help is wrapped to, whatever the terminal.
COLUMNS = '80'


#: The pages, each a title and its commands (a page under 2,500 words each).
GROUPS = {
    'commands.md': ('`gps_error`: fitting and checking',
                    ('calibrate', 'validate', 'diagnose', 'compare')),
    'commands-simulate.md': ('`gps_error`: simulating and importing',
                             ('simulate', 'split', 'import', 'synth', 'scenario')),
}


def render():
    """Return {page file name: its text}."""
    os.environ['COLUMNS'] = COLUMNS
    from gps_error_ros.cli.parser import command_parsers
    top, commands = command_parsers()
    other = {name: title for name, (title, _) in GROUPS.items()}
    pages = {}
    for name, (title, members) in GROUPS.items():
        links = ' '.join(f'[{t}]({n}).' for n, t in other.items() if n != name)
        out = [f'# {title}', '',
               'The help each command prints (`gps_error COMMAND --help`), generated from '
               'the parsers by `python tools/commands_doc.py`. The other commands: '
               f'{links} The node\'s parameters and topics are in '
               '[the node reference](../node.md).', '']
        if name == 'commands.md':
            out += ['```text', top.format_help().rstrip(), '```', '']
        for cmd in members:
            out += [f'## `gps_error {cmd}`', '', '```text',
                    commands[cmd].format_help().rstrip(), '```', '']
        pages[name] = '\n'.join(out)
    missing = set(commands) - {c for _, members in GROUPS.values() for c in members}
    if missing:
        raise SystemExit(f'commands_doc: commands on no page: {sorted(missing)}')
    return pages


def main():
    """Write the page; exit 0."""
    PAGE.parent.mkdir(parents=True, exist_ok=True)
    for name, text in render().items():
        (PAGE.parent / name).write_text(text)
        print(f'wrote {PAGE.parent / name}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

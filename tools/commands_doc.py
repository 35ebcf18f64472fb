"""
Write docs/reference/commands.md from ``gps_error --help`` and each command's ``--help``.

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


def render():
    """Return the page's text."""
    os.environ['COLUMNS'] = COLUMNS
    from gps_error_ros.cli.parser import command_parsers
    top, commands = command_parsers()
    out = ['# Every `gps_error` command', '',
           'The help each command prints (`gps_error COMMAND --help`), generated from the '
           'parsers by `python tools/commands_doc.py`. The node\'s parameters and topics are '
           'in [the node reference](../node.md).', '',
           '```text', top.format_help().rstrip(), '```', '']
    for name, parser in commands.items():
        out += [f'## `gps_error {name}`', '', '```text', parser.format_help().rstrip(),
                '```', '']
    return '\n'.join(out)


def main():
    """Write the page; exit 0."""
    PAGE.parent.mkdir(parents=True, exist_ok=True)
    PAGE.write_text(render())
    print(f'wrote {PAGE}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

"""
Every command block of the README and the docs pages that starts a node runs as written.

The blocks are read from README.md and docs/*.md themselves, so neither can
drift from what the node accepts. ``ros2 run gps_error_ros X`` (ros2cli is not in the
PyPI install) becomes the installed console script X; each run gets a
namespace of its own and is stopped with Ctrl-C after it is up.
"""

from pathlib import Path
import re
import shlex
import time

import pytest

from ros_harness import NodeProcess, unique_ns

ROOT = Path(__file__).resolve().parents[2]
# (docs/index.md is the README copied for the site, when built: not a page of its own)
PAGES = [ROOT / 'README.md'] + sorted(p for p in (ROOT / 'docs').glob('*.md')
                                      if p.name != 'index.md')
NODES = ('gps_error_node', 'gps_calibration_node')


def node_commands():
    """Return the README's and docs pages' node commands as argv lists (lines joined)."""
    blocks = [b for page in PAGES
              for b in re.findall(r'```[a-z]*\n(.*?)```', page.read_text(), re.S)]
    out = []
    for block in blocks:
        text = block.replace('\\\n', ' ')
        for line in text.splitlines():
            if not any(n in line for n in NODES):
                continue
            argv = shlex.split(line, comments=True)
            if argv[:3] == ['ros2', 'run', 'gps_error_ros']:
                argv = argv[3:]
            if argv and Path(argv[0]).name in NODES:
                out.append(argv)
    return out


def test_the_readme_has_node_commands():
    names = [Path(a[0]).name for a in node_commands()]
    assert names.count('gps_error_node') >= 3, names
    readme = [b for b in re.findall(r'```[a-z]*\n(.*?)```', PAGES[0].read_text(), re.S)
              if 'gps_error_node' in b]
    assert len(readme) >= 2, 'the README shows the node with PyPI and with colcon'


@pytest.mark.integration
@pytest.mark.parametrize('argv', node_commands(), ids=lambda a: ' '.join(a)[:60])
def test_readme_node_command_runs_as_written(argv):
    args = list(argv[1:])
    ns = unique_ns()
    if '--ros-args' in args:
        args += ['-r', f'__ns:={ns}']
    else:
        args += ['--ros-args', '-r', f'__ns:={ns}']
    node = NodeProcess(args, name=Path(argv[0]).name)
    assert node.wait_output('profile', 'calibrating from'), node.stop()[1]   # its start line
    time.sleep(1.0)
    assert node.proc.poll() is None, node.stop()[1]     # and still running
    rc, log = node.stop()
    assert rc == 0 and 'Traceback' not in log, log
    assert 'profile' in log or 'calibrating from' in log, log

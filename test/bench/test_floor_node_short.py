"""The node benchmark's floor, short: it starts, serves its agents' topics and stops cleanly."""

import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration
FLOOR = Path(__file__).resolve().parents[2] / 'bench' / 'floor_node.py'


@pytest.mark.parametrize('reliability', ['reliable', 'best_effort'])
def test_floor_node_runs_and_reports(reliability):
    proc = subprocess.Popen([sys.executable, str(FLOOR), '3', reliability, '--ros-args',
                             '-r', '__ns:=/floor_smoke'],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        # started when it says so (on a loaded machine its imports take seconds)
        first, deadline = '', time.monotonic() + 60.0
        while not first and proc.poll() is None and time.monotonic() < deadline:
            if select.select([proc.stdout], [], [], 1.0)[0]:
                first = proc.stdout.readline()
        assert first.startswith('floor node: serving 3 agents'), first
        time.sleep(1.0)
        assert proc.poll() is None, proc.communicate()[0]
        proc.send_signal(signal.SIGINT)       # as bench_node.py stops it
        out = proc.communicate(timeout=20)[0]
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, out
    # in the node's summary format, which bench_node.py parses for both
    sys.path.insert(0, str(FLOOR.parent))
    from bench_node import SUMMARY
    assert 'at shutdown:' in out and SUMMARY.search(out), out

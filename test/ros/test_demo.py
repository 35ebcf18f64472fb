"""`make demo`'s program, shortened: bag, figure and summary are real."""

import json
import subprocess
import sys

import pytest

from gps_error_ros.traces.bag_io import read_messages

pytestmark = pytest.mark.integration


def test_short_demo(tmp_path):
    out = subprocess.run(
        [sys.executable, '-m', 'gps_error_ros.ros.demo', '--out', str(tmp_path),
         '--hours', '0.1', '--seed', '3'],
        capture_output=True, text=True, timeout=240)
    assert out.returncode == 0, out.stdout + out.stderr
    assert 'fixes received: 361 of 361' in out.stdout
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert summary['fixes'] == 361 and summary['gaps'] == 0
    assert summary['node_exit_code'] == 0
    png = (tmp_path / 'demo.png').read_bytes()
    assert png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 50_000
    assert (tmp_path / 'demo_bag' / 'metadata.yaml').exists()
    assert list((tmp_path / 'demo_bag').glob('*.mcap'))
    msgs = read_messages(tmp_path / 'demo_bag', ['/pose', '/fix'])
    assert len(msgs['/fix']) == 361 and len(msgs['/pose']) == 361 * 5
    for d in ('north', 'east'):
        assert abs(summary[d]['mean_m']) < 60 and 0 < summary[d]['sd_m'] < 40

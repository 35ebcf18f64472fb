"""`make demo`'s program, shortened: bag, figure and summary are real."""

import json
import subprocess
import sys

import matplotlib.pyplot as plt
import numpy as np
import pytest

from gps_error_ros.model.profiles import load_profile
from gps_error_ros.model.streams import agent_keys
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
    img = plt.imread(tmp_path / 'demo.png')
    assert img.shape[:2] == (810, 1260)                  # 14 x 9 in at 90 dpi
    w = img.shape[1] // 3
    for panel in (img[:, :w], img[:405, w:2 * w], img[405:, 2 * w:]):
        assert (panel[..., :3].min(axis=-1) < 0.6).mean() > 0.002   # drawn on
    datum = summary['datum']
    assert f'datum {datum}' in out.stdout
    # the printed datum is all it takes to calibrate the demo's own bag
    cal = subprocess.run(
        [sys.executable, '-m', 'gps_error_ros.cli', 'calibrate', str(tmp_path / 'demo_bag'),
         '--datum', ','.join(map(str, datum)), '-o', str(tmp_path / 'demo.yaml')],
        capture_output=True, text=True, timeout=120)
    assert cal.returncode == 0, cal.stderr
    assert '361 of 361 fixes paired' in cal.stdout
    assert (tmp_path / 'demo_bag' / 'metadata.yaml').exists()
    assert list((tmp_path / 'demo_bag').glob('*.mcap'))
    msgs = read_messages(tmp_path / 'demo_bag', ['/pose', '/fix'])
    assert len(msgs['/fix']) == 361 and len(msgs['/pose']) == 361 * 5
    # the profile's figures beside the measured ones are DS5's own, and the walk's SD is
    # a plausible 361 s of DS5: inside the 0.5-99.5 % range of 400 simulated agents' SDs
    model = load_profile('DS5').model()
    sims = model.simulate(agent_keys(11, [f'a{i}' for i in range(400)]), 361).std(axis=0)
    for a, d in enumerate(('north', 'east')):
        assert summary[d]['theory_sd_m'] == pytest.approx(model.stationary_sd[a], rel=1e-12)
        assert summary[d]['theory_mean_m'] == pytest.approx(model.mean[a], abs=1e-12)
        lo, hi = np.quantile(sims[:, a], [0.005, 0.995])
        assert lo < summary[d]['sd_m'] < hi, (d, summary[d]['sd_m'], lo, hi)

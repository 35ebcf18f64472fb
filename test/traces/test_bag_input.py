"""Calibration from real rosbag2 files (MCAP and SQLite3), and bad bags."""

import subprocess
import sys

import numpy as np
import pytest

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.traces.bag_io import BagError
from gps_error_ros.traces.loading import load_trace
from gps_error_ros.traces.pairing import PairingError
from gps_error_ros.model.profiles import load_profile_file
from bag_helpers import write_walk_bag

DATUM = (52.52, 13.40, 40.0)
NORTH = AxisParams(0.4, (1.2, -0.35), 0.5)
EAST = AxisParams(-0.2, (0.85, 0.0), 0.8)


def yw_se(params, n):
    """Return the asymptotic SE of Yule-Walker phi: sqrt(diag(s2 G^-1)/n)."""
    model = ARErrorModel(params, params)
    acv = model.autocovariance(params.order)[:, 0, 0]
    p = params.order
    gamma = np.array([[acv[abs(i - j)] for j in range(p)] for i in range(p)])
    return np.sqrt(np.diag(params.sigma_w ** 2 * np.linalg.inv(gamma)) / n)


@pytest.mark.parametrize('storage, truth', [('mcap', 'pose'),
                                            ('sqlite3', 'navsatfix')])
def test_round_trip_through_a_bag(tmp_path, storage, truth):
    n = 5000
    err = ARErrorModel(NORTH, EAST).simulate(streams.agent_key(21), n)[:, 0]
    jitter = np.random.default_rng(1).uniform(-0.05, 0.05, n)
    fix_t = 1000.0 + np.arange(n) + jitter
    bag = tmp_path / 'walk'
    write_walk_bag(bag, storage, DATUM, err, fix_t, truth=truth)
    out = tmp_path / 'fitted.yaml'
    cmd = [sys.executable, '-m', 'gps_error_ros.cli', 'calibrate', str(bag),
           '-o', str(out), '--truth-topic', '/truth', '--order', '2']
    if truth == 'pose':
        cmd += ['--datum', ','.join(map(str, DATUM))]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert f'{n} of {n} fixes paired' in r.stdout
    p = load_profile_file(out)
    assert p.fit['samples'] == n and p.fit['segments'] == 1
    for axis, true in (('north', NORTH), ('east', EAST)):
        got = p.axes[axis]
        se = yw_se(true, n)
        assert np.all(np.abs(np.array(got.phi) - true.phi) < 5 * se), (axis, got)
        assert abs(got.sigma_w - true.sigma_w) < 5 * true.sigma_w / np.sqrt(2 * n)


def test_no_fix_and_gaps(tmp_path):
    n = 400
    err = np.zeros((n, 2)) + np.random.default_rng(2).normal(0, 1, (n, 2))
    statuses = [0] * n
    for i in (10, 11, 12):
        statuses[i] = -1
    bag = tmp_path / 'b'
    write_walk_bag(bag, 'mcap', DATUM, err, 50.0 + np.arange(n), statuses=statuses)
    trace, notes = load_trace(bag, '/fix', '/truth', DATUM)
    assert len(trace) == n - 3
    assert any('3 fixes skipped' in s for s in notes)


def test_bag_errors_name_what_is_there(tmp_path):
    bag = tmp_path / 'b'
    write_walk_bag(bag, 'mcap', DATUM, np.zeros((20, 2)), 50.0 + np.arange(20.0))
    with pytest.raises(BagError, match=r'/gps not in the bag; it has: /fix '
                                       r'\(sensor_msgs/msg/NavSatFix\), /truth'):
        load_trace(bag, '/gps', '/truth', DATUM)
    with pytest.raises(BagError, match='/truth has type .*expected sensor_msgs'):
        load_trace(bag, '/truth', '/fix', DATUM)
    with pytest.raises(BagError, match='--datum'):
        load_trace(bag, '/fix', '/truth', None)
    with pytest.raises(BagError, match='not a rosbag2 \\(no metadata.yaml'):
        load_trace(tmp_path, '/fix', '/truth', DATUM)


def test_truncated_bag(tmp_path):
    bag = tmp_path / 'b'
    write_walk_bag(bag, 'mcap', DATUM, np.zeros((300, 2)), 50.0 + np.arange(300.0))
    mcap = next(bag.glob('*.mcap'))
    data = mcap.read_bytes()
    mcap.write_bytes(data[:len(data) // 2])
    with pytest.raises(BagError, match='truncated or corrupt|cannot open'):
        load_trace(bag, '/fix', '/truth', DATUM)


def test_no_overlap_and_backwards_time(tmp_path):
    from gps_error_ros.traces.pairing import pair
    with pytest.raises(PairingError, match='do not overlap'):
        pair([100.0, 101.0], [0, 0], [0, 0], [0.0, 1.0], [0, 0], [0, 0])
    with pytest.raises(PairingError, match='fixes: time going backwards'):
        pair([2.0, 1.0], [0, 0], [0, 0], [0.0, 5.0], [0, 0], [0, 0])
    with pytest.raises(PairingError, match='truth: duplicate stamp'):
        pair([2.0, 3.0], [0, 0], [0, 0], [0.0, 0.0, 5.0], [0, 0, 0], [0, 0, 0])


def test_never_interpolates_across_a_truth_gap():
    from gps_error_ros.traces.pairing import pair
    truth_t = np.r_[np.arange(0, 10, 0.2), np.arange(30, 40, 0.2)]
    ones = np.ones(truth_t.size)
    fix_t = np.arange(0.5, 39.5, 1.0)
    tr, stats = pair(fix_t, 0 * fix_t, 0 * fix_t, truth_t, ones, ones)
    assert stats.in_truth_gap == 20 and stats.paired == fix_t.size - 20


def test_diagnose_reads_a_bag_and_finds_correlated_innovations(tmp_path):
    import json
    n = 1500
    model = ARErrorModel(NORTH, EAST, innovation_corr=0.5)
    err = model.simulate(streams.agent_keys(8, ['bag']), n)[:, 0]
    bag = tmp_path / 'walk'
    write_walk_bag(bag, 'mcap', DATUM, err, 50.0 + np.arange(float(n)))
    out = tmp_path / 'd.json'
    r = subprocess.run(
        [sys.executable, '-m', 'gps_error_ros.cli', 'diagnose', str(bag),
         '--truth-topic', '/truth', '--datum', ','.join(map(str, DATUM)),
         '--json', str(out), '--sims', '20'],
        capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    d = json.loads(out.read_text())
    assert d['samples'] == n
    assert [e['name'] for e in d['effects']] == ['cross_axis_coupling']
    assert d['unexplained'] == []
    assert d['error_after']['heldout_nll_per_sample'] < \
        d['error_before']['heldout_nll_per_sample']

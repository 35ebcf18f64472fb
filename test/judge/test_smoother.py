"""GTSAM's iSAM2 as a consumer of the fixes, and ``compare --smoother``."""

import json
import math

import numpy as np
import pytest

from gps_error_ros.cli import main as cli
from gps_error_ros.judge.smoother import head, run_smoother, SMOOTHER_MEASURES
from gps_error_ros.fit.holdout import Part
from gps_error_ros.sim.synthetic import synthetic_trace
from gps_error_ros.traces.trace_io import write_trace_csv


def _walk(n):
    t = np.arange(n, dtype=float)
    return Part([np.zeros((n, 2))], [np.stack([1.2 * t, 0.3 * t], axis=1)], [t])


def test_the_smoother_follows_a_walk_and_shrugs_off_failed_fixes():
    n, var = 300, np.array([4.0, 9.0])
    rng = np.random.default_rng(2)
    white = rng.normal(0.0, np.sqrt(var), (n, 2))
    failed = white.copy()
    bad = rng.random(n) < 0.03
    failed[bad] += rng.normal(0.0, 300.0, (bad.sum(), 2))       # fixes hundreds of m off
    online_rms, online_p95, smooth_rms = run_smoother(
        _walk(n), np.stack([np.zeros((n, 2)), white, failed]), var).T
    raw = math.sqrt(var.sum())
    assert online_rms[0] < 1.0                       # exact fixes: the odometry's drift
    assert online_rms[1] < 0.5 * raw                 # the odometry averages the noise
    assert smooth_rms[1] < online_rms[1]             # the whole track knows more
    assert online_p95[1] > online_rms[1]
    # the Huber loss keeps failed fixes from dragging the track
    assert online_rms[2] < 1.5 * online_rms[1], online_rms


def test_head_keeps_the_first_samples_and_their_segments():
    part = Part([np.zeros((5, 2)), np.ones((5, 2))], [np.zeros((5, 2))] * 2,
                [np.arange(5.0), 10.0 + np.arange(5.0)])
    short = head(part, 7)
    assert [len(e) for e in short.err] == [5, 2] and short.t[1].tolist() == [10.0, 11.0]


def test_compare_feeds_the_smoother_real_and_simulated_fixes(tmp_path, capsys):
    paths = [write_trace_csv(synthetic_trace('none', seed, n), tmp_path / f'r{seed}.csv')
             for seed, n in ((1, 900), (2, 900), (3, 200))]
    out = tmp_path / 'folds.json'
    assert cli(['compare', str(paths[0]), str(paths[1]), '--test', str(paths[2]),
                '--sims', '20', '--smoother', '4', '--json', str(out)]) == 0
    assert 'smoother' in capsys.readouterr().out
    (fold,) = json.loads(out.read_text())['folds']
    for name, c in fold['classes'].items():
        assert 0.0 <= c['groups']['smoother'] <= 1.0, name
        for m in SMOOTHER_MEASURES:
            row = c['measures'][f'smoother:{m}']
            assert math.isfinite(row['measured']) and row['sim_lo'] <= row['sim_hi'], (name, m)


def test_the_smoother_goes_with_folds_and_within_the_sims(tmp_path):
    path = write_trace_csv(synthetic_trace('none', 1, 600), tmp_path / 'one.csv')
    with pytest.raises(SystemExit) as exc:
        cli(['compare', str(path), '--smoother', '3'])
    assert '--smoother goes with --folds or --test' in str(exc.value)
    with pytest.raises(SystemExit) as exc:
        cli(['compare', str(path), '--folds', 'rolling', '--sims', '20', '--smoother', '30'])
    assert 'expected at most --sims (20)' in str(exc.value)

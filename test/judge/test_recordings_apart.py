"""
Held-out recordings judged together: every consumer and statistic keeps them apart.

Two walks held out at once are two runs, in two places, each with its own
bias: a filter restarts at each one's start, and their autocorrelation is
taken within each and pooled, never across the jump between them.
"""

import json
from dataclasses import replace

import numpy as np

from gps_error_ros.cli import main as cli
from gps_error_ros.judge.consumers import run_filter
from gps_error_ros.fit.fidelity import acf_by_axis
from gps_error_ros.fit.holdout import cut_trace
from gps_error_ros.model.geodesy import offset
from gps_error_ros.traces.trace_io import join_recordings, Trace, write_trace_csv


def _white_walk(name, seed, n, lat0, bias_n):
    """Return a straight walk at ``lat0`` with white errors (SD 5 m) about ``bias_n`` m north."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    truth_lat, truth_lon = offset(lat0, -1.25, 1.2 * t, np.zeros(n))
    e = rng.normal(0.0, 5.0, (n, 2)) + [bias_n, 0.0]
    lat, lon = offset(truth_lat, truth_lon, e[:, 0], e[:, 1])
    return Trace(name, t, np.asarray(lat), np.asarray(lon), np.asarray(truth_lat),
                 np.asarray(truth_lon))


def _walks():
    # three walks kilometres apart, biases 12 m apart: nearly white within each
    return [_white_walk('a', 1, 900, 51.75, 0.0), _white_walk('b', 2, 900, 51.77, 6.0),
            _white_walk('c', 3, 900, 51.79, -6.0)]


def test_a_joined_trace_says_which_recording_each_row_came_from():
    a, b, c = _walks()
    ab = join_recordings([a, b])
    assert sorted(set(ab.extra['recording'])) == [0, 1]
    # joined again, the recordings already joined stay apart
    abc = join_recordings([ab, c])
    np.testing.assert_array_equal(abc.extra['recording'],
                                  np.repeat([0, 1, 2], 900).astype(float))
    train, test, _, _ = cut_trace(abc, cut_t=float(abc.t[900]))
    assert set(train.recordings()) == {0} and set(test.recordings()) == {1, 2}
    assert sum(test.recording_starts()) == 2


def test_the_filter_restarts_at_each_recording_and_the_acf_stays_within():
    a, b, c = _walks()
    _, test, _, _ = cut_trace(join_recordings([a, b, c]), cut_t=float(900 + 100))
    errors = np.concatenate(test.err)[None]
    rms = run_filter(test, errors, np.array([25.0, 25.0]))[0, 0]
    # a filter carried from one walk to the next, 2 km away, rejected every fix after
    # the jump and ran on the velocity aid alone (an RMS of kilometres)
    assert rms < 15.0, rms
    within = acf_by_axis(test.err, 10, test.recording)
    assert np.all(np.abs(within[[0, 9]]) < 0.1), within
    # pooled about one mean, the biases' difference reads as persistence
    pooled = acf_by_axis(test.err, 10)
    assert pooled[0, 0] > 0.4, pooled


def test_compare_with_two_recordings_held_out_judges_each_apart(tmp_path):
    a, b, c = _walks()
    d = replace(_white_walk('d', 4, 900, 51.81, 3.0), name='d')
    paths = [write_trace_csv(w, tmp_path / f'{w.name}.csv') for w in (a, b, c, d)]
    out = tmp_path / 'folds.json'
    assert cli(['compare', str(paths[0]), str(paths[1]), '--test', str(paths[2]),
                str(paths[3]), '--sims', '20', '--json', str(out)]) == 0
    (fold,) = json.loads(out.read_text())['folds']
    measures = fold['classes']['white_bias']['measures']
    assert measures['filter:filter_rms_m']['measured'] < 15.0, measures['filter:filter_rms_m']
    assert abs(measures['persistence:acf1_north']['measured']) < 0.1

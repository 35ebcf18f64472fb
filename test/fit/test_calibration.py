"""Calibration: statsmodels as oracle, round trips, gaps, bad input."""

import subprocess
import sys

import numpy as np
import pytest
from statsmodels.tsa.stattools import pacf as sm_pacf

from gps_error_ros.fit.autocorrelation import durbin_levinson, pooled_autocovariance
from gps_error_ros.fit.calibration import calibrate, CalibrationError, errors_on_grid
from gps_error_ros.model.profiles import load_profile_file
from gps_error_ros.traces.trace_io import read_trace_csv, Trace, TraceError
from trace_helpers import NORTH, synthetic_trace, TRUTH, write_csv


def test_pacf_matches_statsmodels():
    trace, err = synthetic_trace(3000)
    acv, n, _ = pooled_autocovariance([err[:, 0]], 10)
    ours, _ = durbin_levinson(acv, 10)
    oracle = sm_pacf(err[:, 0], nlags=10, method='ldbiased')[1:]
    np.testing.assert_allclose(ours, oracle, atol=1e-10)


def test_round_trip_recovers_known_parameters():
    n = 20000
    trace, _ = synthetic_trace(n, seed=4)
    res = calibrate(trace, order=3)
    # Large-sample SE of Yule-Walker phi is about 1/sqrt(n) scaled by the
    # inverse autocorrelation matrix; 6/sqrt(n) is a loose 5-sigma for these.
    np.testing.assert_allclose(res.north.params.phi, NORTH.phi, atol=6 / np.sqrt(n))
    assert abs(res.north.params.sigma_w - NORTH.sigma_w) < 5 * 0.6 / np.sqrt(2 * n)
    res1 = calibrate(trace, order=1)
    assert abs(res1.east.params.phi[0] - 0.8) < 5 * np.sqrt((1 - 0.64) / n)
    assert abs(res1.east.params.sigma_w - 0.9) < 5 * 0.9 / np.sqrt(2 * n)
    # the paper's order choice finds the AR(1) axis; BIC is recorded beside it
    free = calibrate(trace)
    assert free.east.bic_order == 1
    assert free.north.pacf_order >= 2


def test_gaps_split_segments_and_are_never_bridged():
    trace, err = synthetic_trace(600, drop=range(200, 230))
    grid = errors_on_grid(trace)
    assert [len(s) for s in grid.segments] == [200, 370]
    assert grid.starts == (0, 230)
    np.testing.assert_allclose(grid.segments[1][:, 0], err[200:, 0], atol=1e-6)
    acv, n, mean = pooled_autocovariance(grid.axis(0), 1)
    d0, d1 = grid.segments[0][:, 0] - mean, grid.segments[1][:, 0] - mean
    expected = (d0[:-1] @ d0[1:] + d1[:-1] @ d1[1:]) / 570
    assert acv[1] == pytest.approx(expected)


def test_cli_writes_a_profile_the_node_loads(tmp_path):
    trace, _ = synthetic_trace(3000, seed=9)
    csv = tmp_path / 'walk.csv'
    write_csv(csv, trace)
    out = tmp_path / 'mine.yaml'
    exe = [sys.executable, '-m', 'gps_error_ros.cli']
    r = subprocess.run(exe + ['calibrate', str(csv), '-o', str(out), '--order', '3'],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    p = load_profile_file(out)
    assert p.name == 'mine' and p.axes['north'].order == 3
    assert p.fit['samples'] == 3000 and p.fit['segments'] == 1
    assert p.fit['order_selection']['east']['order_fixed_by_user'] is True
    assert len(p.fit['order_selection']['north']['pacf']) == 10


def test_refusals():
    trace, _ = synthetic_trace(30)
    with pytest.raises(CalibrationError, match='too few'):
        calibrate(trace)
    # Biased Yule-Walker fits are stationary by construction; what cannot be
    # fitted is a series without variation (e.g. a receiver that froze).
    n = 500
    ones = np.ones(n)
    with pytest.raises(CalibrationError, match='constant'):
        calibrate(Trace('frozen', np.arange(n, dtype=float), TRUTH[0] * ones,
                        TRUTH[1] * ones, TRUTH[0] * ones, TRUTH[1] * ones))


@pytest.mark.parametrize('text, match', [
    ('t,lat,lon,truth_lat\n0,1,2,3\n1,1,2,3\n', "missing column.*truth_lon"),
    ('t,lat,lon,truth_lat,truth_lon\n0,1,x,3,4\n1,1,2,3,4\n', "line 2.*'lon'.*'x'"),
    ('t,lat,lon,truth_lat,truth_lon\n0,1,2,3,4\n0,1,2,3,4\n', 'line 3: duplicate'),
    ('t,lat,lon,truth_lat,truth_lon\n1,1,2,3,4\n0,1,2,3,4\n', 'line 3: decreasing'),
    ('t,lat,lon,truth_lat,truth_lon\n', '0 data row'),
    ('t,lat,lon,truth_lat,truth_lon\n0,1,2,3,4\n', '1 data row'),
    ('', 'empty file'),
    ('t,lat,lon,truth_lat,truth_lon\n0,95,2,3,4\n1,1,2,3,4\n', 'out of range'),
])
def test_bad_csv(tmp_path, text, match):
    f = tmp_path / 'bad.csv'
    f.write_text(text)
    with pytest.raises(TraceError, match=match) as exc:
        read_trace_csv(f)
    assert str(f) in str(exc.value)


def test_bom_and_crlf_are_accepted(tmp_path):
    f = tmp_path / 'win.csv'
    f.write_bytes('\ufefft,lat,lon,truth_lat,truth_lon,alt\r\n'
                  '0,1,2,3,4,\r\n1,1,2,3,4,5\r\n'.encode('utf-8'))
    tr = read_trace_csv(f)
    assert len(tr) == 2 and np.isnan(tr.extra['alt'][0])


def test_damage_note_names_lost_steps_and_truth_gaps():
    from gps_error_ros.fit.calibration import damage_note
    whole, _ = synthetic_trace(1000)
    assert damage_note(errors_on_grid(whole), 1000, 0) is None
    holed, _ = synthetic_trace(1000, drop=range(100, 1000, 20))     # 5 % lost
    note = damage_note(errors_on_grid(holed), 955, 0)
    assert '45 of 1000 steps missing' in note and 'slower' in note
    assert 'gaps of the truth' in damage_note(errors_on_grid(whole), 1000, 30)


def test_calibrate_says_how_little_data_it_had(tmp_path, capsys):
    """216 samples (the new user's phone): the span, the PACF's bound and both orders."""
    from gps_error_ros.cli import main as gps_error
    from gps_error_ros.fit.calibration import little_data_note
    short, _ = synthetic_trace(216, seed=4)
    note = little_data_note(calibrate(short))
    assert note.startswith('216 samples (3.6 min) is little data')
    assert '+-0.133' in note and 'north PACF' in note and 'BIC' in note
    assert little_data_note(calibrate(synthetic_trace(600, seed=4)[0])) is None
    src = write_csv(tmp_path / 'short.csv', short)
    assert gps_error(['calibrate', str(src), '-o', str(tmp_path / 'p.yaml')]) == 0
    said = capsys.readouterr().out
    assert 'note: 216 samples (3.6 min) is little data' in said
    assert 'compare and diagnose need 180 to train on and 80 held out' in said
    assert 'mean error' in said and 'stationary SD' in said


def test_a_calibration_result_says_what_it_fitted():
    """summary() is the text calibrate prints of the fit; to_dict() the profile it writes."""
    from gps_error_ros.model.profiles import profile_from_dict
    result = calibrate(synthetic_trace(3000, seed=4)[0])
    text = result.summary(max_order=10)
    lines = text.splitlines()
    assert lines[0].startswith(f'{result.input}: {result.grid.n} samples in 1 segment(s)')
    assert lines[1].startswith('  north: AR(') and lines[2].startswith('  east: AR(')
    profile = profile_from_dict(result.to_dict('mine'))
    assert profile.name == 'mine'
    np.testing.assert_allclose(profile.axes['north'].phi, result.north.params.phi, atol=1e-6)
    assert result.to_dict()['fit']['gross_failures']['count'] == 0

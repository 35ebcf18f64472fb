"""The paper's truth: landmarks, the times they were passed, constant speed between."""

import numpy as np
import pytest

from gps_error_ros.cli import main as cli
from gps_error_ros.model.geodesy import offset
from gps_error_ros.sim.landmark_method import landmark_error
from gps_error_ros.traces.landmarks import landmark_truth, LandmarkError
from gps_error_ros.traces.trace_io import read_trace_csv
from trace_helpers import gpx_file

T0 = 1714564800.0                          # 2024-05-01T12:00:00Z


def files(tmp_path, passes):
    lm = tmp_path / 'landmarks.csv'
    lm.write_text('name,lat,lon\nA,40.0,-74.0\nB,40.001,-74.0\nC,40.001,-73.999\n')
    ps = tmp_path / 'passes.csv'
    ps.write_text('time,landmark\n' + ''.join(f'{t},{n}\n' for t, n in passes))
    return lm, ps


def test_the_truth_moves_at_constant_speed_between_passes(tmp_path):
    lm, ps = files(tmp_path, [('2024-05-01T12:00:00Z', 'A'), (T0 + 80, 'B'),
                              (T0 + 100, 'B'), (T0 + 160, 'C')])      # B: a 20 s wait
    t, lat, lon, _ = landmark_truth(lm, ps)
    assert t.tolist() == [T0, T0 + 80, T0 + 100, T0 + 160]
    # a phone on that route, 3 m north of the truth: its errors come out 3 m
    pts = []
    for k in range(0, 161, 2):
        la, lo = np.interp(T0 + k, t, lat), np.interp(T0 + k, t, lon)
        la, lo = offset(la, lo, 3.0, 0.0)
        pts.append((f'2024-05-01T12:{k // 60:02d}:{k % 60:02d}Z', float(la), float(lo), 0.0))
    phone = gpx_file(tmp_path / 'phone.gpx', pts)
    out = tmp_path / 'walk.csv'
    assert cli(['import', 'gpx', str(phone), '--landmarks', str(lm), '--passes', str(ps),
                '-o', str(out)]) == 0
    tr = read_trace_csv(out)
    assert len(tr) == 81
    np.testing.assert_allclose((tr.lat - tr.truth_lat) * 111_000, 3.0, atol=0.05)


def test_bad_landmark_files_name_what_is_wrong(tmp_path, capsys):
    lm, ps = files(tmp_path, [(T0, 'A'), (T0 + 10, 'Z')])
    with pytest.raises(LandmarkError, match="landmark 'Z' is not in"):
        landmark_truth(lm, ps)
    lm, ps = files(tmp_path, [(T0, 'A'), (T0 - 10, 'B')])
    with pytest.raises(LandmarkError, match='increasing times'):
        landmark_truth(lm, ps)
    lm, ps = files(tmp_path, [('noon', 'A'), (T0, 'B')])
    with pytest.raises(LandmarkError, match="time 'noon'"):
        landmark_truth(lm, ps)
    assert cli(['import', 'gpx', 'x.gpx', '--landmarks', str(lm), '-o',
                str(tmp_path / 'o.csv')]) == 2
    assert '--landmarks FILE and --passes FILE' in capsys.readouterr().err


def test_the_methods_error_on_a_simulated_walk():
    """The figures the README quotes (20 one-hour Manhattan walks)."""
    def stats(d):
        return (round(float(np.sqrt(np.mean(d ** 2))), 1), round(float(np.quantile(d, 0.95)), 1))
    assert stats(landmark_error()) == (12.0, 28.3)
    assert stats(landmark_error(press_on_leaving=True)) == (0.0, 0.0)
    assert stats(landmark_error(landmarks='turns')) == (18.2, 38.4)
    assert stats(landmark_error(landmarks='turns', press_on_leaving=True)) == (15.6, 34.3)

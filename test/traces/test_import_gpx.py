"""``gps_error import gpx`` and GPX as a truth: a round trip through gpxpy."""

import numpy as np
import pytest

from gps_error_ros.cli import main as cli
from gps_error_ros.traces.gpx import GpxError, read_gpx
from gps_error_ros.traces.importing import import_recording
from gps_error_ros.traces.trace_io import read_trace_csv
from trace_helpers import gpx_file


def stamp(k):
    return f'2024-05-01T12:00:{k:02d}Z'


def test_a_gpx_recording_against_a_gpx_truth(tmp_path):
    phone = gpx_file(tmp_path / 'phone.gpx',
                     [(stamp(k), 40.0 + 1e-5 * k + 2e-5, -74.0, 10.0) for k in range(0, 30)]
                     + [(None, 40.0, -74.0, 0.0)], extra='<hdop>1.2</hdop>')
    truth = gpx_file(tmp_path / 'truth.gpx',
                     [(stamp(k), 40.0 + 1e-5 * k, -74.0, 5.0) for k in range(0, 31)])
    rec = read_gpx(phone)
    assert rec.t.size == 30 and rec.skipped == {'no time': 1}
    assert np.all(rec.extra['hdop'] == 1.2)
    trace, notes = import_recording('gpx', phone, truth)
    assert len(trace) == 30 and '30 of 30 fixes paired' in notes[2]
    np.testing.assert_allclose(trace.lat - trace.truth_lat, 2e-5, atol=1e-12)
    np.testing.assert_allclose(trace.extra['truth_speed'][1:-1], 1.11, atol=0.01)
    np.testing.assert_allclose(trace.extra['truth_bearing'][1:-1], 0.0, atol=0.01)
    out = tmp_path / 'walk.csv'
    assert cli(['import', 'gpx', str(phone), '--truth', str(truth), '-o', str(out)]) == 0
    assert len(read_trace_csv(out)) == 30


def test_bad_gpx_is_a_clear_error(tmp_path):
    bad = tmp_path / 'bad.gpx'
    bad.write_text('<gpx><trk>')
    with pytest.raises(GpxError, match='not a GPX file'):
        read_gpx(bad)
    untimed = gpx_file(tmp_path / 'u.gpx', [(None, 40.0, -74.0, 0.0)])
    with pytest.raises(GpxError, match='no track point with a time'):
        read_gpx(untimed)

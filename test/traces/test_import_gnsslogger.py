"""``gps_error import gnsslogger``: Android GnssLogger logs, both layouts."""

import numpy as np
import pytest

from gps_error_ros.cli import main as cli
from gps_error_ros.traces.gnsslogger import GnssLoggerError, read_gnsslogger
from gps_error_ros.traces.trace_io import read_trace_csv
from measured import DATA, RAW

LOG = RAW / 'gnsslogger' / 'pseudoranges_log_2016_08_22_14_45_50.txt'
TRUTH = '37.422578,-122.081678,-28'          # the test site, as the data's README gives


def test_the_demo_log_against_its_point_reproduces_the_shipped_trace(tmp_path, capsys):
    out = tmp_path / 'static.csv'
    assert cli(['import', 'gnsslogger', str(LOG), '--truth', TRUTH, '-o', str(out)]) == 0
    said = capsys.readouterr().out
    assert '207 of 207 fixes paired' in said
    assert 'no gross failures (more than 5 robust SDs' in said
    ours, ref = read_trace_csv(out), read_trace_csv(DATA / 'gmt-static-phone-2016-08-22.csv')
    np.testing.assert_array_equal(ours.t, ref.t)
    for k in ('lat', 'lon', 'truth_lat', 'truth_lon'):
        np.testing.assert_array_equal(getattr(ours, k), getattr(ref, k))
    for k in ('alt', 'truth_alt', 'speed', 'accuracy'):
        np.testing.assert_array_equal(ours.extra[k], ref.extra[k])


NEW_HEADER = ('# Fix,Provider,LatitudeDegrees,LongitudeDegrees,AltitudeMeters,SpeedMps,'
              'AccuracyMeters,BearingDegrees,UnixTimeMillis,SpeedAccuracyMps,'
              'BearingAccuracyDegrees,elapsedRealtimeNanos,VerticalAccuracyMeters,'
              'MockLocation')


def test_the_newer_layout_is_read_by_its_own_header(tmp_path):
    log = tmp_path / 'new.txt'
    log.write_text('\n'.join([
        '# Version: v3.0.6.0', NEW_HEADER,
        'Fix,GPS,37.1,-122.1,10.0,1.5,3.9,90.0,1700000000000,0.3,5.0,1,2.0,0',
        'Fix,FLP,37.2,-122.2,11.0,1.6,3.0,91.0,1700000000500,0.3,5.0,1,2.0,0',
        'Fix,GPS,37.1001,-122.1,10.0,1.5,3.9,,1700000001000,0.3,5.0,1,2.0,0',
        'Fix,GPS,37.10',                                   # truncated
        'Fix,GPS,abc,-122.1,10.0,1.5,3.9,90.0,1700000002000,0.3,5.0,1,2.0,0']) + '\n')
    rec = read_gnsslogger(log)
    assert rec.t.tolist() == [1700000000.0, 1700000001.0]
    assert rec.extra['bearing'][0] == 90.0 and np.isnan(rec.extra['bearing'][1])
    assert rec.extra['accuracy'].tolist() == [3.9, 3.9]
    assert rec.skipped == {'malformed': 2, 'other provider': 1}
    assert read_gnsslogger(log, provider='flp').t.tolist() == [1700000000.5]


def test_logs_without_fixes_are_clear_errors(tmp_path, capsys):
    raw_only = tmp_path / 'raw.txt'
    raw_only.write_text('# Raw,ElapsedRealtimeMillis,TimeNanos\nRaw,1,2\n')
    with pytest.raises(GnssLoggerError, match='no "# Fix,..." header'):
        read_gnsslogger(raw_only)
    empty = tmp_path / 'empty.txt'
    empty.write_text(NEW_HEADER + '\n')
    with pytest.raises(GnssLoggerError, match="no usable Fix record of provider 'gps'"):
        read_gnsslogger(empty)
    out = tmp_path / 'o.csv'
    assert cli(['import', 'gnsslogger', str(empty), '--truth', TRUTH, '-o', str(out)]) == 2
    assert 'no usable Fix record' in capsys.readouterr().err and not out.exists()

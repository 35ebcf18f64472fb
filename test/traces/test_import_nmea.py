"""``gps_error import nmea`` on the real raw files of data/, and broken ones."""

import numpy as np
import pytest

from gps_error_ros.cli import main as cli
from gps_error_ros.traces.importing import import_nmea
from gps_error_ros.traces.nmea import NmeaError, read_nmea
from gps_error_ros.traces.trace_io import read_trace_csv
from measured import DATA, RAW

GSDC = RAW / 'gsdc2020-mtv1'


def test_phone_against_span_reproduces_the_shipped_trace(tmp_path, capsys):
    out = tmp_path / 'pixel4.csv'
    assert cli(['import', 'nmea', str(GSDC / 'Pixel4_chipset.nmea'), '--truth',
                str(GSDC / 'SPAN_Pixel4_10Hz.nmea'), '-o', str(out)]) == 0
    log = capsys.readouterr().out
    assert '1737 of 1737 fixes paired' in log
    assert '23771 bad checksum skipped' in log        # the SPAN's RMC, all wrong
    ours, ref = read_trace_csv(out), read_trace_csv(DATA / 'gsdc2020-mtv1-pixel4.csv')
    assert len(ours) == len(ref) == 1737
    np.testing.assert_array_equal(ours.t, ref.t)
    for k in ('lat', 'lon', 'truth_lat', 'truth_lon'):
        np.testing.assert_allclose(getattr(ours, k), getattr(ref, k), atol=1e-6, rtol=0)
    for k in ('alt', 'truth_alt', 'speed', 'hdop', 'bearing'):
        a, b = ours.extra[k], ref.extra[k]
        np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b), err_msg=k)
        np.testing.assert_allclose(a[np.isfinite(a)], b[np.isfinite(b)], atol=1e-6)
    # the truth's course from the chord of its positions, as the README describes
    a, b = ours.extra['truth_bearing'], ref.extra['truth_bearing']
    np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b))
    d = (a - b + 180.0) % 360.0 - 180.0
    assert np.nanmax(np.abs(d)) < 0.01
    # truth speed: from the chord here, from the SPAN's 1 Hz RMC in the file
    assert np.nanmax(np.abs(ours.extra['truth_speed'] - ref.extra['truth_speed'])) < 0.5


def test_the_imported_trace_calibrates(tmp_path):
    trace, _ = import_nmea(GSDC / 'Pixel4XLModded_chipset.nmea',
                           GSDC / 'SPAN_Pixel4XLModded_10Hz.nmea')
    ref = read_trace_csv(DATA / 'gsdc2020-mtv1-pixel4xlmodded.csv')
    assert len(trace) == len(ref)
    np.testing.assert_allclose(trace.lat, ref.lat, atol=1e-6, rtol=0)


def test_a_fixed_point_is_a_truth(tmp_path):
    trace, notes = import_nmea(GSDC / 'Pixel4_chipset.nmea', '37.42,-122.09,-30')
    assert len(trace) == 1737 and np.all(trace.truth_lat == 37.42)
    assert 'fixed point' in notes[1]


def write(path, lines):
    path.write_text('\n'.join(lines) + '\n')
    return path


GGA = '$GPGGA,221046.00,3725.415069,N,12205.647326,W,7,,0.38,-32.83,M,0.0,M,0.0,0000*73'
RMC = '$GPRMC,221046.00,A,3725.415069,N,12205.647326,W,000.0,000.0,140520,,,A*47'


def test_broken_sentences_are_counted_never_used(tmp_path):
    lines = GSDC.joinpath('Pixel4_chipset.nmea').read_text().splitlines()[:40]
    lines[4] = lines[4][:30]                              # truncated
    lines[6] = lines[6][:-2] + ('00' if lines[6][-2:] != '00' else '11')   # bad checksum
    fixes = read_nmea(write(tmp_path / 'x.nmea', lines))
    assert fixes.t.size == 18                             # epochs 2 and 3 lost their GGA
    assert fixes.skipped['bad checksum'] == 2             # the truncated one too
    talker = read_nmea(write(tmp_path / 'gn.nmea', [
        '$GNGGA,221046.00,3725.415069,N,12205.647326,W,7,,0.38,-32.83,M,0.0,M,0.0,0000*6D',
        '$GNRMC,221046.00,A,3725.415069,N,12205.647326,W,000.0,000.0,140520,,,A*59']))
    assert talker.t.size == 1


def test_midnight_rolls_the_date(tmp_path):
    def sentence(body):
        c = 0
        for ch in body:
            c ^= ord(ch)
        return f'${body}*{c:02X}'
    lines = []
    for tod, date in (('235959.00', '140520'), ('000000.00', None), ('000001.00', None)):
        lines.append(sentence(f'GPGGA,{tod},3725.415069,N,12205.647326,W,1,,0.38,'
                              f'-32.83,M,0.0,M,,'))
        if date:
            lines.append(sentence(f'GPRMC,{tod},A,3725.415069,N,12205.647326,W,0.0,,'
                                  f'{date},,,A'))
    fixes = read_nmea(write(tmp_path / 'm.nmea', lines))
    np.testing.assert_allclose(np.diff(fixes.t), [1.0, 1.0])


def test_bad_recordings_are_clear_errors(tmp_path, capsys):
    with pytest.raises(NmeaError, match='no usable GGA fix'):
        read_nmea(write(tmp_path / 'rmc.nmea', [RMC]))
    with pytest.raises(NmeaError, match='date'):
        read_nmea(write(tmp_path / 'gga.nmea', [GGA]))
    out = tmp_path / 'o.csv'
    assert cli(['import', 'nmea', str(GSDC / 'Pixel4_chipset.nmea'), '--truth',
                str(write(tmp_path / 'late.nmea', [GGA.replace('221046', '231046')
                                                   .replace('*73', '*72')])),
                '-o', str(out)]) == 2
    err = capsys.readouterr().err
    assert '1 truth sample(s): need at least 2 to interpolate' in err, err
    assert not out.exists()


def test_a_truth_without_dates_takes_the_given_one(tmp_path, capsys):
    """The SPAN file's RMC all fail their checksums: the date comes from elsewhere."""
    span = GSDC / 'SPAN_Pixel4_10Hz.nmea'
    phone = GSDC / 'Pixel4_chipset.nmea'
    out = tmp_path / 'o.csv'
    assert cli(['import', 'nmea', str(phone), '--truth', str(span), '--truth-date',
                '2020-05-14', '-o', str(out)]) == 0
    assert '1737 of 1737 fixes paired' in capsys.readouterr().out
    assert cli(['import', 'nmea', str(phone), '--truth', str(span), '--truth-date',
                '2020-05-15', '-o', str(out)]) == 2          # a day off: no overlap
    assert 'do not overlap the truth' in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli(['import', 'nmea', str(phone), '--truth', str(span), '--truth-date', 'May',
             '-o', str(out)])
    assert "'May': expected YYYY-MM-DD" in capsys.readouterr().err

"""
Property-based tests of the recording readers and of the fits on what they give.

Generated and corrupted inputs: a reader either refuses with its documented
error or returns usable fixes (finite, in range, times increasing); a fit on
any trace either refuses with CalibrationError or gives a profile with no NaN
or infinity anywhere, and no warning reaches the user.
"""

import functools
import math
import warnings

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np

from gps_error_ros.fit.calibration import calibrate, CalibrationError
from gps_error_ros.fit.gross_failures import find_gross_failures
from gps_error_ros.model.geodesy import offset
from gps_error_ros.model.profiles import profile_from_dict
from gps_error_ros.traces.gnsslogger import GnssLoggerError, read_gnsslogger
from gps_error_ros.traces.gpx import GpxError, read_gpx
from gps_error_ros.traces.landmarks import landmark_truth, LandmarkError
from gps_error_ros.traces.nmea import NmeaError, read_nmea
from gps_error_ros.traces.trace_io import Trace

SETTINGS = settings(max_examples=120, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


def _no_warnings(fn):
    """Run the test with every warning an error: nothing may reach the user's terminal."""
    @functools.wraps(fn)
    def run(*args, **kwargs):
        with warnings.catch_warnings():
            warnings.simplefilter('error')
            with np.errstate(all='raise'):
                return fn(*args, **kwargs)
    return run


def _usable(rec):
    assert rec.t.size >= 1
    assert np.all(np.isfinite(rec.t)) and np.all(np.diff(rec.t) > 0)
    assert np.all(np.isfinite(rec.lat)) and np.all(np.abs(rec.lat) <= 90)
    assert np.all(np.isfinite(rec.lon)) and np.all(np.abs(rec.lon) <= 180)


def _checksum(body):
    c = 0
    for ch in body:
        c ^= ord(ch)
    return f'${body}*{c:02X}'


numbers = st.one_of(st.floats(-1e4, 1e4).map(lambda v: f'{v:.4f}'),
                    st.text(alphabet='0123456789.-+eE', max_size=8))
gga = st.builds(lambda hh, mm, ss, lat, ns, lon, ew, q, hdop, alt: _checksum(
    f'GPGGA,{hh:02d}{mm:02d}{ss:05.2f},{lat},{ns},{lon},{ew},{q},08,{hdop},{alt},M,0.0,M,,'),
    st.integers(0, 30), st.integers(0, 70), st.floats(0, 70), numbers,
    st.sampled_from('NSX'), numbers, st.sampled_from('EWX'), st.sampled_from('0127x'),
    numbers, numbers)
rmc = st.builds(lambda hh, mm, ss, lat, lon, kn, course, dd, mo: _checksum(
    f'GPRMC,{hh:02d}{mm:02d}{ss:05.2f},A,{lat},N,{lon},W,{kn},{course},{dd:02d}{mo:02d}20,,,A'),
    st.integers(0, 23), st.integers(0, 59), st.floats(0, 59.99), numbers, numbers,
    numbers, numbers, st.integers(0, 35), st.integers(0, 14))
noise = st.text(max_size=40)


@SETTINGS
@given(st.lists(st.one_of(gga, rmc, noise, gga.map(lambda s: s[:-1] + 'Z')), max_size=25))
@_no_warnings
def test_nmea_reader(tmp_path_factory, lines):
    f = tmp_path_factory.mktemp('n') / 'x.nmea'
    f.write_text('\r\n'.join(lines))
    try:
        rec = read_nmea(f)
    except NmeaError:
        return
    _usable(rec)


fix_line = st.builds(
    lambda lat, lon, alt, spd, acc, ms: f'Fix,gps,{lat},{lon},{alt},{spd},{acc},{ms}',
    numbers, numbers, numbers, numbers, numbers,
    st.one_of(st.integers(1_400_000_000_000, 1_500_000_000_000).map(str), numbers))


@SETTINGS
@given(st.lists(st.one_of(fix_line, noise, st.just('Fix,network,1,2,3,4,5,6')), max_size=25),
       st.booleans())
@_no_warnings
def test_gnsslogger_reader(tmp_path_factory, lines, header):
    f = tmp_path_factory.mktemp('g') / 'x.txt'
    head = ['# Fix,Provider,Latitude,Longitude,Altitude,Speed,Accuracy,(UTC)TimeInMs'] \
        if header else []
    f.write_text('\n'.join(head + lines))
    try:
        rec = read_gnsslogger(f)
    except GnssLoggerError:
        return
    _usable(rec)


trkpt = st.builds(lambda lat, lon, ele, t: (
    f'<trkpt lat="{lat}" lon="{lon}"><ele>{ele}</ele>' + (f'<time>{t}</time>' if t else '')
    + '</trkpt>'),
    numbers, numbers, numbers,
    st.one_of(st.none(), st.builds(lambda s: f'2020-05-14T22:{s // 60:02d}:{s % 60:02d}Z',
                                   st.integers(0, 3599)), noise))


@SETTINGS
@given(st.lists(st.one_of(trkpt, noise), max_size=15), st.booleans())
@_no_warnings
def test_gpx_reader(tmp_path_factory, points, closed):
    f = tmp_path_factory.mktemp('x') / 'x.gpx'
    f.write_text('<?xml version="1.0"?><gpx version="1.0" creator="t" '
                 'xmlns="http://www.topografix.com/GPX/1/0"><trk><trkseg>'
                 + ''.join(points) + ('</trkseg></trk></gpx>' if closed else ''))
    try:
        rec = read_gpx(f)
    except GpxError:
        return
    _usable(rec)


@SETTINGS
@given(st.lists(st.tuples(st.sampled_from(['a', 'b', 'c', '']), numbers, numbers),
                max_size=5),
       st.lists(st.tuples(st.sampled_from(['a', 'b', 'c', 'd']),
                          st.one_of(numbers, st.just('2020-05-14T22:00:00Z'), noise)),
                max_size=6))
@_no_warnings
def test_landmark_truth(tmp_path_factory, places, passes):
    d = tmp_path_factory.mktemp('l')
    (d / 'l.csv').write_text('name,lat,lon\n' + '\n'.join(','.join(p) for p in places))
    (d / 'p.csv').write_text('name,t\n' + '\n'.join(','.join(p) for p in passes))
    try:
        t, lat, lon, alt = landmark_truth(d / 'l.csv', d / 'p.csv')
    except LandmarkError:
        return
    assert np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)
    assert np.all(np.abs(lat) <= 90) and np.all(np.abs(lon) <= 180)


def _finite_everywhere(value, where='profile'):
    if isinstance(value, dict):
        for k, v in value.items():
            _finite_everywhere(v, f'{where}.{k}')
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            _finite_everywhere(v, f'{where}[{i}]')
    elif isinstance(value, float):
        assert math.isfinite(value), where


@st.composite
def traces(draw):
    """Draw a trace with AR errors, gaps, jittered stamps, failures and odd accuracy values."""
    n = draw(st.integers(3, 400))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    scale = draw(st.sampled_from([0.0, 1e-3, 1.0, 30.0]))
    phi = draw(st.sampled_from([0.0, 0.5, 0.99]))
    e = np.zeros((n, 2))
    for k in range(1, n):
        e[k] = phi * e[k - 1] + scale * rng.standard_normal(2)
    if draw(st.booleans()):                     # quantised, as phones write positions
        e = np.round(e / 0.5) * 0.5
    bad = rng.random(n) < draw(st.sampled_from([0.0, 0.02, 0.3]))
    e[bad] += rng.choice([-1, 1], (bad.sum(), 2)) * rng.uniform(500, 30000, (bad.sum(), 2))
    steps = np.cumsum(rng.choice([1, 1, 1, 2, 7], n)) if draw(st.booleans()) else np.arange(n)
    t = steps * draw(st.sampled_from([1.0, 0.993, 1.004])) + rng.uniform(0, 0.3, n) * 0.01
    t = np.maximum.accumulate(t + np.arange(n) * 1e-6)
    lat, lon = offset(51.76, -1.25, e[:, 0], e[:, 1])
    extra = {}
    kind = draw(st.sampled_from(['none', 'good', 'odd']))
    if kind != 'none':
        acc = np.abs(e).sum(axis=1) * 0.7 + 3.0
        if kind == 'odd':
            acc[rng.random(n) < 0.3] = rng.choice([0.0, -1.0, np.nan, 1e9])
        extra['accuracy'] = acc
    vkind = draw(st.sampled_from(['none', 'good', 'odd']))
    if vkind != 'none':                         # Doppler speed and course, and the truth's
        truth_speed = np.abs(rng.normal(8.0, 8.0, n)) * (rng.random(n) > 0.1)
        truth_course = rng.uniform(0.0, 360.0, n)
        extra.update(truth_speed=truth_speed, truth_bearing=truth_course,
                     speed=np.abs(truth_speed + rng.normal(0.0, 0.3, n)),
                     bearing=(truth_course + rng.normal(0.0, 3.0, n)) % 360.0)
        if vkind == 'odd':
            for key in ('speed', 'bearing', 'truth_speed', 'truth_bearing'):
                hit = rng.random(n) < 0.2
                extra[key][hit] = rng.choice([np.nan, -1.0, 0.0, 720.0, 1e9], hit.sum())
    ones = np.ones(n)
    return Trace('fuzz', t, np.asarray(lat), np.asarray(lon), 51.76 * ones, -1.25 * ones,
                 extra)


@settings(max_examples=60, deadline=None)
@given(st.lists(traces(), min_size=1, max_size=3))
@_no_warnings
def test_calibrate_gives_a_finite_profile_or_says_why(recordings):
    for tr in recordings:
        found = find_gross_failures(tr)
        assert found.count == len(found.t) and np.all(np.isfinite(found.size_m))
    try:
        res = calibrate(recordings)
    except CalibrationError:
        return
    prof = res.profile_dict('fuzz')
    _finite_everywhere(prof)
    model = profile_from_dict(prof).model()         # what calibrate writes loads
    assert np.all(np.isfinite(model.stationary_cov))

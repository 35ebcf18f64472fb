"""NMEA out: sentences a reader parses, with checksums, back to the same fixes."""

import datetime as dt
import math

import numpy as np
import pynmea2
import pytest

from gps_error_ros.traces.nmea import read_nmea
from gps_error_ros.model.accuracy import radius68
from gps_error_ros.traces.nmea_write import (checksum, ellipse, epoch_sentences, GPSD_UERE_M,
                                             KNOT)

T0 = dt.datetime(2026, 11, 28, 23, 59, 50, tzinfo=dt.timezone.utc)


def test_the_checksum_is_the_xor_of_the_body():
    # the NMEA 0183 standard's own GGA example
    body = 'GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,'
    assert checksum(body) == '47'


def test_an_ellipse_of_a_covariance():
    major, minor, orient = ellipse([[4.0, 0.0], [0.0, 1.0]])
    assert (major, minor, orient) == (2.0, 1.0, 0.0)      # long axis north
    major, minor, orient = ellipse([[1.0, 0.0], [0.0, 9.0]])
    assert (major, minor, orient) == (3.0, 1.0, 90.0)     # long axis east
    major, minor, orient = ellipse([[2.0, 1.0], [1.0, 2.0]])
    assert major == pytest.approx(math.sqrt(3)) and orient == pytest.approx(45.0)


def test_fixes_written_and_read_back(tmp_path):
    rng = np.random.default_rng(3)
    n = 40
    lat = rng.uniform(-89.9, 89.9, n)
    lon = rng.uniform(-179.9, 179.9, n)
    lat[0], lon[0] = 40.7505699999999, -73.99999999999     # minutes that round up to 60
    alt = rng.uniform(-50.0, 3000.0, n)
    speed, course = rng.uniform(0.1, 30.0, n), rng.uniform(0.0, 360.0, n)
    fix = np.ones(n, dtype=bool)
    fix[[5, 6, 20]] = False
    sd = np.stack([rng.uniform(1.0, 9.0, n), rng.uniform(1.0, 9.0, n)], axis=1)
    lines = []
    for k in range(n):
        cov = [[sd[k, 0] ** 2, 0.3], [0.3, sd[k, 1] ** 2]]
        lines += epoch_sentences(T0 + dt.timedelta(seconds=k), lat[k], lon[k], alt[k],
                                 bool(fix[k]), cov, 4.0, speed[k], course[k])
    path = tmp_path / 'out.nmea'
    path.write_text('\r\n'.join(lines) + '\r\n')
    rec = read_nmea(path)
    # the epochs without a fix are left out (quality 0), counted; the rest come back whole
    assert rec.skipped['no fix'] == 3 and rec.skipped['bad checksum'] == 0
    t = T0.timestamp() + np.flatnonzero(fix)
    np.testing.assert_allclose(rec.t, t, atol=1e-6)         # across midnight: the next day
    np.testing.assert_allclose(rec.lat, lat[fix], atol=1e-9)
    np.testing.assert_allclose(rec.lon, lon[fix], atol=1e-9)
    np.testing.assert_allclose(rec.alt, alt[fix], atol=1e-3)
    np.testing.assert_allclose(rec.extra['speed'], speed[fix], rtol=1e-4)
    np.testing.assert_allclose(rec.extra['bearing'], course[fix], atol=0.01)
    # HDOP x gpsd's 19 m is the fix's 95 % radius (to the HDOP's 2 decimals)
    cov = np.array([[[a * a, 0.3], [0.3, b * b]] for a, b in sd[fix]])
    np.testing.assert_allclose(rec.extra['hdop'] * GPSD_UERE_M, radius68(cov, 0.95),
                               atol=0.005 * GPSD_UERE_M)


def test_gst_states_the_covariance_and_no_fix_has_no_position():
    t = T0.replace(hour=12)
    lines = epoch_sentences(t, 40.5, -73.25, 10.0, True, [[9.0, 0.0], [0.0, 4.0]], 6.0,
                            1.4 * 2, 90.0)
    kinds = [pynmea2.parse(s, check=True).sentence_type for s in lines]
    assert kinds == ['GGA', 'GSA', 'GST', 'RMC']
    gst = pynmea2.parse(lines[2], check=True)
    assert (float(gst.std_dev_latitude), float(gst.std_dev_longitude),
            float(gst.std_dev_altitude)) == (3.0, 2.0, 6.0)
    assert (gst.std_dev_major, gst.std_dev_minor, gst.orientation) == (3.0, 2.0, 0.0)
    rmc = pynmea2.parse(lines[3], check=True)
    assert rmc.status == 'A' and float(rmc.spd_over_grnd) == pytest.approx(2.8 / KNOT, abs=1e-3)
    none = epoch_sentences(t, math.nan, math.nan, math.nan, False)
    kinds = [pynmea2.parse(s, check=True) for s in none]
    assert [k.sentence_type for k in kinds] == ['GGA', 'GSA', 'RMC']     # no accuracy to state
    gga, gsa, rmc = kinds
    assert gga.gps_qual == 0 and gga.lat == '' and gsa.mode_fix_type == '1'
    assert rmc.status == 'V'

"""Metres to degrees and back agree with pyproj's topocentric frame to mm."""

import numpy as np
import pytest

from gps_error_ros.model.geodesy import difference, GeodesyError, \
    LocalTangentFrame, offset


@pytest.mark.parametrize('lat, lon', [(40.75, -73.99), (22.30, 114.18),
                                      (-33.87, 151.21), (69.65, 18.96)])
def test_offset_matches_tangent_plane(lat, lon):
    rng = np.random.default_rng(0)
    north, east = rng.normal(0, 30, 200), rng.normal(0, 30, 200)
    lat2, lon2 = offset(lat, lon, north, east)
    frame = LocalTangentFrame(lat, lon, 0.0)
    e, n, _ = frame.to_enu(lat2, lon2, 0.0)
    # Same ellipsoidal height: the tangent plane drops by d^2/2R (< 0.3 mm
    # horizontally at 100 m), so agreement is at the millimetre level.
    np.testing.assert_allclose(n, north, atol=1e-3)
    np.testing.assert_allclose(e, east, atol=1e-3)
    back_n, back_e = difference(lat2, lon2, lat, lon)
    np.testing.assert_allclose(back_n, north, atol=1e-6)
    np.testing.assert_allclose(back_e, east, atol=1e-6)


def test_frame_round_trip_and_scale():
    frame = LocalTangentFrame(40.75057, -73.99065, -23.0)
    lat, lon, alt = frame.to_geodetic(np.array([100.0, -250.0]),
                                      np.array([50.0, 1000.0]), 2.0)
    e, n, u = frame.to_enu(lat, lon, alt)
    np.testing.assert_allclose(e, [100.0, -250.0], atol=1e-6)
    np.testing.assert_allclose(n, [50.0, 1000.0], atol=1e-6)
    # 1 km north is ~0.00900 deg of latitude
    assert abs((lat[1] - 40.75057) * 111_030 - 1000) < 5


@pytest.mark.parametrize('datum', [(91.0, 0.0), (0.0, 181.0),
                                   (float('nan'), 0.0), (90.0, 0.0)])
def test_invalid_datum(datum):
    with pytest.raises(GeodesyError):
        LocalTangentFrame(*datum)

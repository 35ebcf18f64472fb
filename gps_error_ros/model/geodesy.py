"""
WGS84 geodesy: local east-north-up frames and metre offsets, via pyproj.

Two operations are needed:

* :class:`LocalTangentFrame` maps a local map frame (east, north, up metres
  about a datum, as robots and simulators publish poses) to latitude,
  longitude and ellipsoidal height, and back (PROJ's topocentric conversion);
* :func:`offset` moves a geodetic point by north/east metres (the error), and
  :func:`difference` measures the north/east metres between two points. They
  use the geodesic through the point with azimuth ``atan2(east, north)``;
  for GPS-sized offsets (metres to hundreds of metres) this agrees with the
  tangent-plane displacement to well under a millimetre.
"""

from typing import Any

import numpy as np
from pyproj import Geod, Transformer

from gps_error_ros.model.state import FloatArray, Numbers

_GEOD = Geod(ellps='WGS84')


class GeodesyError(ValueError):
    """Coordinates outside their valid range."""


def check_latlon(lat: Numbers, lon: Numbers, what: str = 'position') -> None:
    """Raise :class:`GeodesyError` unless latitude/longitude are valid."""
    lat = np.asarray(lat, dtype=float)
    lon = np.asarray(lon, dtype=float)
    if not (np.all(np.isfinite(lat)) and np.all(np.isfinite(lon))):
        raise GeodesyError(f'{what}: latitude/longitude must be finite')
    if np.any(np.abs(lat) > 90.0):
        raise GeodesyError(f'{what}: latitude must be in [-90, 90] deg, '
                           f'got {lat.ravel()[np.abs(lat.ravel()) > 90][0]}')
    if np.any(np.abs(lon) > 180.0):
        raise GeodesyError(f'{what}: longitude must be in [-180, 180] deg, '
                           f'got {lon.ravel()[np.abs(lon.ravel()) > 180][0]}')


class LocalTangentFrame:
    """
    East-north-up metres about a WGS84 datum ``(lat, lon, alt)``.

    The datum's height is ellipsoidal; ``up`` is along the ellipsoid normal
    at the datum (so far from the datum the frame's up departs from the
    local vertical, as in any flat map frame).
    """

    def __init__(self, lat: float, lon: float, alt: float = 0.0) -> None:
        check_latlon(lat, lon, 'datum')
        if not np.isfinite(alt):
            raise GeodesyError('datum: altitude must be finite')
        if abs(lat) == 90.0:
            raise GeodesyError('datum: a pole has no east direction')
        self.datum = (float(lat), float(lon), float(alt))
        pipeline = (
            '+proj=pipeline '
            '+step +proj=axisswap +order=2,1 '
            '+step +proj=unitconvert +xy_in=deg +xy_out=rad '
            '+step +proj=cart +ellps=WGS84 '
            f'+step +proj=topocentric +ellps=WGS84 '
            f'+lat_0={float(lat)!r} +lon_0={float(lon)!r} +h_0={float(alt)!r}')
        self._to_enu = Transformer.from_pipeline(pipeline)

    def to_geodetic(self, east: Numbers, north: Numbers,
                    up: Numbers = 0.0) -> tuple[Any, ...]:
        """Return (lat, lon, alt) of local ENU coordinates (arrays or floats)."""
        east, north, up = _broadcast(east, north, up)
        return self._to_enu.transform(
            east, north, up, direction='INVERSE', errcheck=True)

    def to_enu(self, lat: Numbers, lon: Numbers,
               alt: Numbers = 0.0) -> tuple[Any, ...]:
        """Return (east, north, up) of geodetic coordinates."""
        lat, lon, alt = _broadcast(lat, lon, alt)
        return self._to_enu.transform(lat, lon, alt, errcheck=True)


def _broadcast(*values: Numbers) -> tuple[Any, ...]:
    """Return floats unchanged, or arrays broadcast to one shape."""
    if all(np.ndim(v) == 0 for v in values):
        return tuple(float(v) for v in values)
    return tuple(np.array(v, dtype=float) for v in np.broadcast_arrays(*values))


def offset(lat: Numbers, lon: Numbers, north: Numbers,
           east: Numbers) -> tuple[Any, Any]:
    """
    Return (lat, lon) of the points ``north``/``east`` metres from (lat, lon).

    Vectorised over numpy arrays.
    """
    north = np.asarray(north, dtype=float)
    east = np.asarray(east, dtype=float)
    az = np.degrees(np.arctan2(east, north))
    dist = np.hypot(north, east)
    lon2, lat2, _ = _GEOD.fwd(
        np.broadcast_to(lon, dist.shape), np.broadcast_to(lat, dist.shape),
        az, dist)
    return lat2, lon2


def difference(lat: Numbers, lon: Numbers, lat_ref: Numbers,
               lon_ref: Numbers) -> tuple[FloatArray, FloatArray]:
    """
    Return (north, east) metres from (lat_ref, lon_ref) to (lat, lon).

    The inverse of :func:`offset`; vectorised over numpy arrays.
    """
    shape = np.broadcast(np.asarray(lat), np.asarray(lon),
                         np.asarray(lat_ref), np.asarray(lon_ref)).shape
    az, _, dist = _GEOD.inv(
        np.broadcast_to(lon_ref, shape), np.broadcast_to(lat_ref, shape),
        np.broadcast_to(lon, shape), np.broadcast_to(lat, shape))
    az = np.radians(az)
    return np.asarray(dist * np.cos(az)), np.asarray(dist * np.sin(az))

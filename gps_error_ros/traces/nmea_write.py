"""
NMEA 0183 out: a receiver's epoch as GGA, GSA, GST and RMC sentences.

What gpsd, ``nmea_navsat_driver`` and a phone's mock-location app read. Each
epoch writes, in this order and with checksums:

* ``GGA``: time, position (eight decimals of a minute: 0.02 mm), fix
  quality (1: a fix, 0: none, as NO_FIX), satellites, HDOP, altitude above
  the ellipsoid (the geoid separation written as 0, so that a reader's
  altitude + separation is the height it was given);
* ``GSA``: the fix mode (3D, or 1 without a fix) and the dilutions (PDOP written
  as the HDOP: the model has no vertical geometry);
* ``GST``: the stated accuracy: the SDs of latitude, longitude and height
  (m) and the error ellipse's semi-axes and orientation (deg from true
  north) of the fix's covariance; its first field, the RMS of the range
  residuals a receiver would give, is written as the horizontal SD (the
  model has no ranges);
* ``RMC``: status A (or V without a fix), date, speed (knots) and course.

The HDOP is the fix's 95 % horizontal radius (of its covariance) over
:data:`GPSD_UERE_M`: gpsd states ``eph`` (its 95 % horizontal error) as
19 m times the HDOP, so gpsd reading the stream states each fix's own 95 %
radius (checked with gpsd 3.22). ``gps_error calibrate`` fits its own metres
per HDOP from a recording, so any constant reads back. Without a fix the
position fields are empty and no GST is written.
"""

from collections.abc import Sequence
import datetime as dt
import math

import numpy as np

from gps_error_ros.model.accuracy import radius68

#: Metres of 95 % horizontal error per unit of HDOP in gpsd (its ``eph`` = 19 m x HDOP).
GPSD_UERE_M = 19.0
#: Satellites GGA and GSA report (the model has none: a plausible constant).
SATELLITES = 10
#: A knot in m/s.
KNOT = 0.514444
#: The talker ID: GP, a GPS receiver (what every reader accepts).
TALKER = 'GP'


def checksum(body: str) -> str:
    """Return the NMEA checksum of a sentence's body (between ``$`` and ``*``): 2 hex digits."""
    value = 0
    for ch in body.encode('ascii'):
        value ^= ch
    return f'{value:02X}'


def sentence(body: str) -> str:
    """Return ``$body*CS`` with its checksum."""
    return f'${body}*{checksum(body)}'


def _angle(value: float, degree_digits: int, hemispheres: str) -> tuple[str, str]:
    """Return (ddmm.mmmmmmmm, hemisphere) of a latitude or longitude in degrees."""
    hemi = hemispheres[0] if value >= 0 else hemispheres[1]
    a = abs(value)
    deg = int(a)
    minutes = (a - deg) * 60.0
    if round(minutes, 8) >= 60.0:       # 59.999999999 rounds up: carry into the degrees
        deg, minutes = deg + 1, 0.0
    return f'{deg:0{degree_digits}d}{minutes:011.8f}', hemi


def _time(t: dt.datetime) -> str:
    return t.strftime('%H%M%S.') + f'{t.microsecond // 10000:02d}'


def ellipse(cov_ne: Sequence[Sequence[float]]) -> tuple[float, float, float]:
    """Return (semi-major SD, semi-minor SD, orientation deg from true north) of a 2x2 N/E."""
    nn, ne, ee = float(cov_ne[0][0]), float(cov_ne[0][1]), float(cov_ne[1][1])
    mid, half = 0.5 * (nn + ee), math.hypot(0.5 * (nn - ee), ne)
    major, minor = math.sqrt(max(mid + half, 0.0)), math.sqrt(max(mid - half, 0.0))
    orientation = math.degrees(0.5 * math.atan2(2.0 * ne, nn - ee)) % 180.0
    return major, minor, orientation


def epoch_sentences(t: dt.datetime, lat: float, lon: float, alt: float, fix: bool,
                    cov_ne: Sequence[Sequence[float]] | None = None,
                    vertical_sd: float = math.nan, speed: float = math.nan,
                    course: float = math.nan) -> list[str]:
    """
    Return one epoch's GGA, GSA, GST (with a fix and a covariance) and RMC sentences.

    ``t``: the UTC instant (timezone-aware); ``lat``, ``lon`` degrees,
    ``alt`` the height above the ellipsoid, m; ``cov_ne`` the fix's stated
    north/east covariance (m^2); ``vertical_sd`` its height's SD, m;
    ``speed`` (m/s) and ``course`` (deg) as reported, NaN for none.
    """
    t = t.astimezone(dt.timezone.utc)
    hms = _time(t)
    fix = bool(fix) and all(math.isfinite(v) for v in (lat, lon, alt))
    lat_s, ns = _angle(lat, 2, 'NS') if fix else ('', '')
    lon_s, ew = _angle(lon, 3, 'EW') if fix else ('', '')
    hdop = ''
    sds = None
    if fix and cov_ne is not None:
        sd_n, sd_e = math.sqrt(max(float(cov_ne[0][0]), 0.0)), \
            math.sqrt(max(float(cov_ne[1][1]), 0.0))
        sds = (sd_n, sd_e)
        r95 = float(radius68(np.asarray(cov_ne, dtype=float), 0.95))
        hdop = f'{r95 / GPSD_UERE_M:.2f}'
    quality, sats = ('1', f'{SATELLITES:02d}') if fix else ('0', '00')
    height = f'{alt:.3f}' if fix else ''
    out = [sentence(f'{TALKER}GGA,{hms},{lat_s},{ns},{lon_s},{ew},{quality},{sats},{hdop},'
                    f'{height},M,0.000,M,,')]
    used = ','.join([f'{k:02d}' for k in range(1, SATELLITES + 1)] if fix else [''] * 12)
    if fix:
        used += ',' * (12 - SATELLITES)
    out.append(sentence(f'{TALKER}GSA,A,{3 if fix else 1},{used},{hdop},{hdop},'))
    if sds is not None and cov_ne is not None:
        major, minor, orient = ellipse(cov_ne)
        vsd = f'{vertical_sd:.3f}' if math.isfinite(vertical_sd) else ''
        out.append(sentence(f'{TALKER}GST,{hms},{math.hypot(*sds):.3f},{major:.3f},'
                            f'{minor:.3f},{orient:.1f},{sds[0]:.3f},{sds[1]:.3f},{vsd}'))
    knots = f'{speed / KNOT:.3f}' if fix and math.isfinite(speed) else ''
    cog = f'{course % 360.0:.2f}' if fix and math.isfinite(course) else ''
    out.append(sentence(f'{TALKER}RMC,{hms},{"A" if fix else "V"},{lat_s},{ns},{lon_s},{ew},'
                        f'{knots},{cog},{t.strftime("%d%m%y")},,,{"A" if fix else "N"}'))
    return out

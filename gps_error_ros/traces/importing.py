"""
``gps_error import``: recordings in the formats phones and receivers write.

A recording (FORMAT ``nmea``: :mod:`.nmea`; ``gnsslogger``:
:mod:`.gnsslogger`; ``gpx``: :mod:`.gpx`) and its truth become a canonical
trace CSV that ``calibrate``, ``validate``, ``diagnose`` and ``compare``
read. The truth is a second recording (a reference receiver's NMEA, a GPX
track: by the file's suffix ``.gpx``, otherwise NMEA), a fixed point
``LAT,LON[,ALT]`` for a static receiver, or landmarks and the times they
were passed (:mod:`.landmarks`, the reference paper's method). Fixes are paired with
the truth interpolated linearly in time to their stamps, never across a
truth gap (:mod:`.pairing`); the truth's speed and course come from the
chord of its positions 0.5 s before and after each fix (empty below
0.2 m/s, where a course means nothing).
"""

import datetime as dt
import math
from typing import Any, Optional

import numpy as np

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.state import FloatArray
from gps_error_ros.traces.gnsslogger import read_gnsslogger
from gps_error_ros.traces.gpx import read_gpx
from gps_error_ros.traces.landmarks import landmark_truth
from gps_error_ros.traces.nmea import read_nmea
from gps_error_ros.traces.pairing import pair
from gps_error_ros.traces.recording import Recording
from gps_error_ros.traces.trace_io import Trace

FORMATS = ('nmea', 'gnsslogger', 'gpx')
#: Below this truth speed (m/s) the truth course is left empty.
MIN_COURSE_SPEED = 0.2


def parse_point(text: str) -> Optional[tuple[float, ...]]:
    """Return (lat, lon, alt) of 'LAT,LON[,ALT]', or None if ``text`` is not one."""
    try:
        v = [float(x) for x in str(text).split(',')]
    except ValueError:
        return None
    if len(v) not in (2, 3) or abs(v[0]) > 90 or abs(v[1]) > 180:
        return None
    return tuple(v + [math.nan] * (3 - len(v)))


def _truth(spec: str | tuple[str, str], fixes: Recording,
           truth_date: Any = None) -> tuple[Any, ...]:
    """
    Return the truth as (t, lat, lon, alt) arrays, and a line for people.

    An NMEA truth without a valid RMC takes ``truth_date`` (a
    ``datetime.date``) or, by default, the UTC date of the first fix.
    """
    if isinstance(spec, tuple):                      # (landmarks CSV, passes CSV)
        t, lat, lon, alt = landmark_truth(*spec)
        return t, lat, lon, alt, (f'truth: {t.size} passes of the landmarks in '
                                  f'{spec[0]}, constant speed in between')
    point = parse_point(spec)
    if point is not None:
        t = np.array([fixes.t[0] - 1.0, fixes.t[-1] + 1.0])
        return (t, np.full(2, point[0]), np.full(2, point[1]), np.full(2, point[2]),
                f'truth: the fixed point {point[0]}, {point[1]}')
    if str(spec).lower().endswith('.gpx'):
        ref = read_gpx(spec)
    else:
        first = truth_date or dt.datetime.fromtimestamp(fixes.t[0], dt.timezone.utc).date()
        ref = read_nmea(spec, date=first)
    return ref.t, ref.lat, ref.lon, ref.alt, f'truth {spec}: {ref.describe()}'


def _chord(t: FloatArray, lat: FloatArray, lon: FloatArray, at: FloatArray,
           half: float = 0.5) -> tuple[FloatArray, FloatArray]:
    """Return speed (m/s) and course (deg) of the truth's chord around ``at``."""
    la0, lo0 = np.interp(at - half, t, lat), np.interp(at - half, t, lon)
    la1, lo1 = np.interp(at + half, t, lat), np.interp(at + half, t, lon)
    north, east = difference(la1, lo1, la0, lo0)
    speed = np.hypot(north, east) / (2 * half)
    course = np.degrees(np.arctan2(east, north)) % 360.0
    course[speed < MIN_COURSE_SPEED] = np.nan
    inside = (at - half >= t[0]) & (at + half <= t[-1])
    speed[~inside], course[~inside] = np.nan, np.nan
    return speed, course


def read_recording(fmt: str, path: PathArg, provider: str = 'gps') -> Recording:
    """Return the :class:`~.recording.Recording` of a recording in ``fmt``."""
    if fmt == 'nmea':
        return read_nmea(path)
    if fmt == 'gnsslogger':
        return read_gnsslogger(path, provider)
    if fmt == 'gpx':
        return read_gpx(path)
    raise ValueError(f'format {fmt!r}: expected one of {list(FORMATS)}')


def import_recording(fmt: str, path: PathArg, truth: str | tuple[str, str],
                     max_truth_gap: Optional[float] = None,
                     provider: str = 'gps', truth_date: Any = None) -> tuple[Trace, list[str]]:
    """Return (Trace, notes) of a recording in ``fmt`` against its truth."""
    fixes = read_recording(fmt, path, provider)
    tt, tlat, tlon, talt, note = _truth(truth, fixes, truth_date)
    if isinstance(truth, tuple) and max_truth_gap is None:
        max_truth_gap = math.inf     # the method bridges from one pass to the next
    trace, stats = pair(fixes.t, fixes.lat, fixes.lon, tt, tlat, tlon,
                        max_truth_gap, str(path))
    used = stats.used
    at = fixes.t[used]
    extra = {'alt': fixes.alt[used], 'truth_alt': np.interp(at, tt, talt)}
    extra.update({k: v[used] for k, v in fixes.extra.items()})
    extra['truth_speed'], extra['truth_bearing'] = _chord(tt, tlat, tlon, at)
    trace = Trace(trace.name, trace.t, trace.lat, trace.lon, trace.truth_lat,
                  trace.truth_lon, extra)
    return trace, [f'{path}: {fixes.describe()}', note, stats.describe()]


def import_nmea(path: PathArg, truth: str,
                max_truth_gap: Optional[float] = None) -> tuple[Trace, list[str]]:
    """Return (Trace, notes) of an NMEA recording against its truth."""
    return import_recording('nmea', path, truth, max_truth_gap)

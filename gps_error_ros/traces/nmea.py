"""
NMEA 0183 recordings in: a phone's or a receiver's GGA, RMC (and GST).

Parsed with ``pynmea2`` (an optional dependency: ``pip install
gps_error_ros[import]``), checksums checked: a sentence with a bad or missing
checksum, or one that does not parse, is skipped and counted, never used.
Talker IDs (GP, GN, GL, GA, BD, ...) are all accepted.

An *epoch* is a UTC instant; its GGA gives the position, the ellipsoidal
height (altitude + geoid separation), the fix quality and HDOP, its RMC the
date, speed (knots, converted to m/s) and course. GGA carries no date: an
epoch takes the date of its RMC, or the last date seen, and a time of day
that goes backwards without a new date moves to the next day (midnight).
Epochs without a GGA position, or with fix quality 0 (no fix), are left out.
"""

import datetime as dt
import math
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.traces.recording import Recording, time_ordered

KNOT = 0.514444                 # m/s per knot (as the data's README uses)


class NmeaError(ValueError):
    """An NMEA file that cannot give fixes (unreadable, nothing usable)."""


def _pynmea2() -> Any:
    try:
        import pynmea2
    except ImportError:
        raise NmeaError('reading NMEA needs pynmea2: pip install '
                        '"gps_error_ros[import]" (or pip install pynmea2)') from None
    return pynmea2


def _num(v: Any) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _sentences(path: PathArg, pynmea2: Any, skipped: dict[str, int]) -> Iterator[Any]:
    """Yield parsed GGA and RMC sentences with valid checksums."""
    try:
        text = Path(path).read_text(encoding='ascii', errors='replace')
    except OSError as exc:
        raise NmeaError(f'{path}: cannot read: {exc}') from None
    for line in text.splitlines():
        line = line.strip()
        if not line.startswith('$'):
            continue
        if line[3:6] not in ('GGA', 'RMC'):
            continue
        try:
            yield pynmea2.parse(line, check=True)
        except pynmea2.ChecksumError:
            skipped['bad checksum'] += 1
        except (pynmea2.ParseError, ValueError, TypeError, AttributeError):
            skipped['unparsable'] += 1


def read_nmea(path: PathArg, date: Any = None) -> Recording:
    """
    Return the :class:`~.recording.Recording` of an NMEA file (module doc).

    Its ``extra`` holds ``speed`` (m/s), ``bearing`` (the RMC course; left
    out where the speed is exactly zero, where receivers write a placeholder)
    and ``hdop``.

    ``date`` (a ``datetime.date``) is the UTC date of the first epoch when the
    file has no RMC with a valid checksum to give one (a reference receiver's
    file whose RMC checksums are all wrong, say).
    """
    pynmea2 = _pynmea2()
    skipped = {'bad checksum': 0, 'unparsable': 0, 'no fix': 0}
    epochs: dict[tuple[int, float], dict[str, Any]] = {}   # (day offset, time of day) ->
    order: list[tuple[int, float]] = []                     # fields
    base, last, day = None, None, 0
    for msg in _sentences(path, pynmea2, skipped):
        try:
            tod = msg.timestamp
        except (ValueError, TypeError):
            tod = None
        if not isinstance(tod, dt.time):        # pynmea2 hands back the text it could not read
            skipped['unparsable'] += 1
            continue
        secs = tod.hour * 3600 + tod.minute * 60 + tod.second + tod.microsecond * 1e-6
        if last is not None and secs < last - 43200:
            day += 1                  # the time of day went round midnight
        last = secs
        if msg.sentence_type == 'RMC' and base is None:
            try:
                stamp = msg.datestamp
            except (ValueError, TypeError):
                stamp = None
            if isinstance(stamp, dt.date):
                base = stamp - dt.timedelta(days=day)
        key = (day, round(secs, 3))
        if key not in epochs:
            epochs[key] = {}
            order.append(key)
        _add(epochs[key], msg, skipped)
    if base is None:
        base = date
    if base is None:
        raise NmeaError(f'{path}: no RMC sentence with a valid checksum gives the '
                        f'date: pass the date of the recording')
    day0 = dt.datetime(base.year, base.month, base.day, tzinfo=dt.timezone.utc).timestamp()
    rows = [(day0 + 86400 * d + secs, e['lat'], e['lon'], e['alt'],
             e.get('speed', math.nan), e.get('course', math.nan), e.get('hdop', math.nan))
            for (d, secs) in order for e in (epochs[(d, secs)],) if 'lat' in e]
    if not rows:
        raise NmeaError(f'{path}: no usable GGA fix in the file; skipped {skipped}')
    a = time_ordered(rows, skipped)
    course = a[:, 5].copy()
    course[a[:, 4] == 0.0] = np.nan             # a placeholder, not a heading
    return Recording(a[:, 0], a[:, 1], a[:, 2], a[:, 3],
                     {'speed': a[:, 4], 'bearing': course, 'hdop': a[:, 6]}, skipped)


def _add(epoch: dict[str, Any], msg: Any, skipped: dict[str, int]) -> None:
    """Put what a GGA or RMC sentence says into its epoch's fields."""
    if msg.sentence_type == 'RMC':
        epoch.update(speed=_num(msg.spd_over_grnd) * KNOT, course=_num(msg.true_course))
        return
    if _num(msg.gps_qual) == 0 or msg.lat == '':
        skipped['no fix'] += 1
        return
    try:
        lat, lon = float(msg.latitude), float(msg.longitude)
    except (ValueError, TypeError):
        lat = lon = math.nan
    if not (math.isfinite(lat) and math.isfinite(lon) and abs(lat) <= 90 and abs(lon) <= 180):
        skipped['unparsable'] += 1
        return
    sep = _num(msg.geo_sep) if msg.geo_sep else 0.0
    epoch.update(lat=lat, lon=lon, alt=_num(msg.altitude) + sep,
                 hdop=_num(msg.horizontal_dil))

"""
Android GnssLogger logs in: the ``Fix`` records of the phone's location output.

A log is text: comment lines start with ``#``, and one of them is the
``# Fix,...`` header that names the fields of the ``Fix`` lines. Both
layouts in use are read by their own header: the older (v1.4:
``Provider, Latitude, Longitude, Altitude, Speed, Accuracy, (UTC)TimeInMs``)
and the newer (``LatitudeDegrees, ..., BearingDegrees, UnixTimeMillis, ...``).
One provider is kept (``gps`` by default; ``fused``, ``network`` are others).
A ``Fix`` line that is truncated or holds a non-number is skipped and counted.
Android's ``Accuracy`` is the 68 % horizontal radius in metres.
"""

import math
from pathlib import Path

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.traces.recording import Recording, time_ordered

#: field -> the names the two layouts give it
FIELDS = {
    'provider': ('Provider',),
    'lat': ('Latitude', 'LatitudeDegrees'),
    'lon': ('Longitude', 'LongitudeDegrees'),
    'alt': ('Altitude', 'AltitudeMeters'),
    'speed': ('Speed', 'SpeedMps'),
    'accuracy': ('Accuracy', 'AccuracyMeters'),
    'bearing': ('Bearing', 'BearingDegrees'),
    'time_ms': ('(UTC)TimeInMs', 'UnixTimeMillis'),
}
REQUIRED = ('provider', 'lat', 'lon', 'time_ms')


class GnssLoggerError(ValueError):
    """A GnssLogger log that cannot give fixes."""


def _columns(header: str, path: PathArg) -> dict[str, int]:
    """Return field -> column index of the ``# Fix,...`` header line."""
    names = [n.strip() for n in header.lstrip('#').split(',')]
    cols = {}
    for field, known in FIELDS.items():
        for i, n in enumerate(names):
            if n in known:
                cols[field] = i
    missing = [f for f in REQUIRED if f not in cols]
    if missing:
        raise GnssLoggerError(f'{path}: the "# Fix" header {names} lacks {missing}: '
                              f'expected a GnssLogger layout')
    return cols


def _value(row: list[str], cols: dict[str, int], field: str) -> float:
    i = cols.get(field)
    if i is None or i >= len(row) or row[i].strip() == '':
        return math.nan
    return float(row[i])


def read_gnsslogger(path: PathArg, provider: str = 'gps') -> Recording:
    """Return the :class:`~.recording.Recording` of ``provider``'s fixes in a log."""
    path = Path(path)
    try:
        lines = path.read_text(encoding='utf-8', errors='replace').splitlines()
    except OSError as exc:
        raise GnssLoggerError(f'{path}: cannot read: {exc}') from None
    header = next((ln for ln in lines if ln.replace(' ', '').startswith('#Fix,')), None)
    if header is None:
        raise GnssLoggerError(f'{path}: no "# Fix,..." header line: not a GnssLogger log')
    cols = _columns(header, path)
    rows, skipped = [], {'malformed': 0, 'other provider': 0}
    for ln in lines:
        if not ln.startswith('Fix,'):
            continue
        row = ln.split(',')
        try:
            if row[cols['provider']].strip().lower() != provider.lower():
                skipped['other provider'] += 1
                continue
            vals = [_value(row, cols, f) for f in
                    ('time_ms', 'lat', 'lon', 'alt', 'speed', 'accuracy', 'bearing')]
        except (IndexError, ValueError):
            skipped['malformed'] += 1
            continue
        if not all(math.isfinite(v) for v in vals[:3]) or abs(vals[1]) > 90 or \
                abs(vals[2]) > 180:
            skipped['malformed'] += 1
            continue
        rows.append(vals)
    if not rows:
        raise GnssLoggerError(f'{path}: no usable Fix record of provider {provider!r} '
                              f'(skipped: {skipped})')
    a = time_ordered(rows, skipped)
    extra = {'speed': a[:, 4], 'accuracy': a[:, 5]}
    if 'bearing' in cols:
        extra['bearing'] = a[:, 6]
    return Recording(a[:, 0] / 1000.0, a[:, 1], a[:, 2], a[:, 3], extra, skipped)

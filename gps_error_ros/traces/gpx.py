"""
GPX tracks in (through ``gpxpy``, the optional ``import`` extra).

Every track point with a time becomes a fix: latitude, longitude, elevation
(GPX gives height above the geoid or the ellipsoid as the writer chose; it
is passed on as written) and, where the writer added them, ``hdop`` and the
speed and course of GPX 1.0 (``<speed>``, ``<course>``). Track points are
taken from every track and segment, in time order; points without a time are
skipped and counted.
"""

import math
from pathlib import Path
from typing import Any

import numpy as np

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.traces.recording import Recording, time_ordered


class GpxError(ValueError):
    """A GPX file that cannot give fixes."""


def _gpxpy() -> Any:
    try:
        import gpxpy
    except ImportError:
        raise GpxError('reading GPX needs gpxpy: pip install "gps_error_ros[import]" '
                       '(or pip install gpxpy)') from None
    return gpxpy


def _num(v: Any) -> float:
    return math.nan if v is None else float(v)


def read_gpx(path: PathArg) -> Recording:
    """Return the :class:`~.recording.Recording` of a GPX file's track points."""
    gpxpy = _gpxpy()
    path = Path(path)
    try:
        with open(path, encoding='utf-8') as f:
            doc = gpxpy.parse(f)
    except OSError as exc:
        raise GpxError(f'{path}: cannot read: {exc}') from None
    except gpxpy.gpx.GPXException as exc:
        raise GpxError(f'{path}: not a GPX file: {exc}') from None
    rows, skipped = [], {'no time': 0}
    for track in doc.tracks:
        for segment in track.segments:
            for p in segment.points:
                if p.time is None:
                    skipped['no time'] += 1
                    continue
                if not (abs(p.latitude) <= 90 and abs(p.longitude) <= 180):
                    skipped['position out of range'] = skipped.get('position out of range',
                                                                   0) + 1
                    continue
                rows.append((p.time.timestamp(), p.latitude, p.longitude,
                             _num(p.elevation), _num(p.speed), _num(p.course),
                             _num(p.horizontal_dilution)))
    if not rows:
        raise GpxError(f'{path}: no track point with a time (skipped: {skipped})')
    a = time_ordered(rows, skipped)
    extra = {}
    for i, name in ((4, 'speed'), (5, 'bearing'), (6, 'hdop')):
        if np.isfinite(a[:, i]).any():
            extra[name] = a[:, i]
    return Recording(a[:, 0], a[:, 1], a[:, 2], a[:, 3], extra, skipped)

"""
The reference paper's truth: landmarks and the times the walker passed them.

A landmarks CSV (``name, lat, lon`` and optionally ``alt``) and a passes CSV
(``time``, ``landmark``: the instants the walker passed each landmark,
logged by a button press on the phone or written down) give the truth: at
each pass the landmark's position, in between constant speed along the
straight line to the next landmark (put a landmark at every turn of the
route). A walker who stops at a landmark passes it twice: on arrival and on
leaving. ``time`` is UTC, as seconds since 1970 or ISO 8601
(``2016-08-22T21:45:55Z``), on the recording's clock.
"""

import csv
import datetime as dt
import math
from pathlib import Path
from typing import Sequence

import numpy as np

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.state import FloatArray


class LandmarkError(ValueError):
    """Landmark or pass files that cannot give a truth."""


def _rows(path: PathArg, need: Sequence[str]) -> list[dict[str, str]]:
    path = Path(path)
    try:
        rows = list(csv.DictReader(path.read_text(encoding='utf-8-sig').splitlines()))
    except OSError as exc:
        raise LandmarkError(f'{path}: cannot read: {exc}') from None
    if not rows or any(c not in rows[0] for c in need):
        raise LandmarkError(f'{path}: expected a CSV with columns {list(need)}')
    return rows


def _time(text: str, path: PathArg, line: int) -> float:
    text = text.strip()
    try:
        return float(text)
    except ValueError:
        pass
    try:
        when = dt.datetime.fromisoformat(text.replace('Z', '+00:00'))
    except ValueError:
        raise LandmarkError(f'{path}: line {line}: time {text!r}: expected seconds '
                            f'since 1970 or ISO 8601') from None
    if when.tzinfo is None:
        when = when.replace(tzinfo=dt.timezone.utc)
    return when.timestamp()


def landmark_truth(landmarks_csv: PathArg, passes_csv: PathArg
                   ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Return the truth (t, lat, lon, alt arrays) of landmarks and their passes."""
    places = {}
    for i, r in enumerate(_rows(landmarks_csv, ('name', 'lat', 'lon')), start=2):
        try:
            alt = float(r['alt']) if r.get('alt') not in (None, '') else math.nan
            places[r['name'].strip()] = (float(r['lat']), float(r['lon']), alt)
        except ValueError:
            raise LandmarkError(f'{landmarks_csv}: line {i}: expected numbers for '
                                f'lat, lon (and alt)') from None
    times: list[float] = []
    pos = []
    for i, r in enumerate(_rows(passes_csv, ('time', 'landmark')), start=2):
        name = r['landmark'].strip()
        if name not in places:
            raise LandmarkError(f'{passes_csv}: line {i}: landmark {name!r} is not in '
                                f'{landmarks_csv} (it has {sorted(places)[:10]})')
        times.append(_time(r['time'], passes_csv, i))
        pos.append(places[name])
    t = np.asarray(times, dtype=float)
    if t.size < 2 or np.any(np.diff(t) <= 0):
        raise LandmarkError(f'{passes_csv}: expected at least 2 passes at increasing '
                            f'times')
    p = np.asarray(pos, dtype=float)
    return t, p[:, 0], p[:, 1], p[:, 2]

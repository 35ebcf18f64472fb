"""
Per-zone calibration: one profile per zone of a map, from one trace.

``gps_error calibrate INPUT --zones MAP -o OUT_DIR`` places every sample of
the trace (on the model grid, as :func:`calibrate` does) in the zone its
truth is in, and fits each zone's samples alone:

* A zone's samples are split into segments wherever the walk left the zone
  or a step is missing, so no autocovariance product spans time spent
  elsewhere.
* A zone needs at least :data:`MIN_ZONE_SAMPLES` samples (300, five
  minutes at 1 Hz: the PACF's significance bound is then 0.11, and an AR(3)
  fit's coefficients have standard errors of about 0.06). A zone with fewer,
  or whose fit is refused (not stationary), keeps the fallback: the profile
  fitted on the whole trace, which is also the map's ``default_profile``.
* Zone profiles carry the AR fit only: outages and velocity are properties
  of the phone and the run, fitted on the whole trace into the fallback (a
  zone's gaps include the time spent outside it, which are not outages).

Written: ``OUT_DIR/all.yaml`` (the whole trace), ``OUT_DIR/<zone>.yaml`` per
fitted zone, and ``OUT_DIR/zones.geojson``: the input map's polygons, each
``profile`` pointing at its zone's file (or ``all.yaml``), with properties
``samples``, ``fitted`` and, for a fallback, ``reason``.
"""

from dataclasses import dataclass
import json
import os
from pathlib import Path
import re
from typing import Optional, Sequence

import numpy as np

from gps_error_ros.fit.calibration import (calibrate, CalibrationError, CalibrationResult,
                                           errors_on_grid, GriddedErrors)
from gps_error_ros.fit.yule_walker import AxisFit, DEFAULT_MAX_ORDER, fit_axis
from gps_error_ros.model.ar_model import AXES
from gps_error_ros.model.atomic import atomic_output
from gps_error_ros.model.profiles import load_profile_file, profile_mapping, write_profile
from gps_error_ros.model.state import BoolArray, IntArray
from gps_error_ros.model.zones import ZoneMap
from gps_error_ros.traces.trace_io import Trace

#: Fewest grid samples a zone needs for a profile of its own (see module doc).
MIN_ZONE_SAMPLES = 300
FALLBACK = 'all'


@dataclass(frozen=True)
class ZoneFit:
    """One zone's outcome: its samples, and its fit or why it has none."""

    name: str
    samples: int
    segments: int
    fits: Optional[tuple[AxisFit, AxisFit]] = None          # (north, east), or None
    reason: str = ''


def _zone_grid(grid: GriddedErrors, steps: IntArray, mask: BoolArray) -> GriddedErrors:
    """Return the samples where ``mask`` holds as a grid, cut where the run breaks."""
    idx = np.flatnonzero(mask)
    if grid.rows is None:
        raise ValueError('a grid without its trace rows cannot be split by zone')
    err = np.concatenate(grid.segments)[idx]
    st = steps[idx]
    cuts = np.flatnonzero((np.diff(st) > 1) | (np.diff(idx) > 1)) + 1
    return GriddedErrors(tuple(np.split(err, cuts)),
                         tuple(int(s[0]) for s in np.split(st, cuts)) if idx.size else (),
                         grid.rate_hz, grid.rows[idx])


def calibrate_zones(trace: Trace, zone_map: ZoneMap, order: Optional[int] = None,
                    max_order: int = DEFAULT_MAX_ORDER, min_samples: int = MIN_ZONE_SAMPLES,
                    rate_hz: float = 1.0) -> tuple[CalibrationResult, list[ZoneFit]]:
    """Return (the whole trace's CalibrationResult, [ZoneFit per zone])."""
    whole = calibrate(trace, order, max_order, rate_hz)
    grid = errors_on_grid(trace, rate_hz)
    steps = np.concatenate([s + np.arange(len(seg)) for s, seg in
                            zip(grid.starts, grid.segments)])
    zone = zone_map.lookup(trace.truth_lat[grid.rows], trace.truth_lon[grid.rows])
    out = []
    for z, name in enumerate(zone_map.names):
        mask = zone == z
        n = int(mask.sum())
        if n < min_samples:
            out.append(ZoneFit(name, n, 0, reason=f'{n} samples, fewer than {min_samples}'))
            continue
        zg = _zone_grid(grid, steps, mask)
        try:
            fits = (fit_axis(zg.axis(0), order, max_order, axis=AXES[0]),
                    fit_axis(zg.axis(1), order, max_order, axis=AXES[1]))
        except CalibrationError as exc:
            out.append(ZoneFit(name, n, len(zg.segments), reason=f'fit refused: {exc}'))
            continue
        out.append(ZoneFit(name, n, len(zg.segments), fits))
    return whole, out


def file_stem(name: str) -> str:
    """Return a file name for zone ``name`` (letters, digits, _ and - kept)."""
    stem = re.sub(r'[^A-Za-z0-9_-]+', '_', name).strip('_') or 'zone'
    return stem if stem != FALLBACK else f'{stem}_zone'


def write_zone_profiles(out_dir: str | os.PathLike[str], trace_name: str,
                        map_path: str | os.PathLike[str], zone_map: ZoneMap,
                        whole: CalibrationResult, fits: Sequence[ZoneFit]) -> Path:
    """Write the profiles and the zone map (see module doc); return the map's path."""
    import shapely.geometry
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    fallback = out_dir / f'{FALLBACK}.yaml'
    write_profile(fallback, whole.profile_dict(f'{Path(trace_name).stem}-all'))
    load_profile_file(fallback)
    features, stems = [], set()
    for poly, fit in zip(zone_map.polygons, fits):
        props = {'name': fit.name, 'samples': fit.samples, 'fitted': fit.fits is not None}
        if fit.fits is None:
            props.update(profile=fallback.name, reason=fit.reason)
        else:
            stem = file_stem(fit.name)
            while stem in stems:
                stem += '_'
            stems.add(stem)
            path = out_dir / f'{stem}.yaml'
            write_profile(path, profile_mapping(
                f'{Path(trace_name).stem}-{stem}', f'zone {fit.name} of {map_path}',
                f'gps_error calibrate {trace_name} --zones {map_path}',
                (fit.fits[0].params, fit.fits[1].params), rate_hz=whole.grid.rate_hz,
                fit={'method': 'Yule-Walker, biased autocovariance pooled over the '
                               'zone\'s segments', 'input': trace_name, 'zone': fit.name,
                     'samples': fit.samples, 'segments': fit.segments,
                     'order_selection': {ax: f.evidence() for ax, f in
                                         zip(AXES, fit.fits)}}))
            load_profile_file(path)
            props['profile'] = path.name
        features.append({'type': 'Feature', 'properties': props,
                         'geometry': shapely.geometry.mapping(poly)})
    dst = out_dir / 'zones.geojson'
    with atomic_output(dst) as tmp:
        # one feature per line: a person can read the map and diff it
        Path(tmp).write_text(
            '{"type": "FeatureCollection", "default_profile": '
            + json.dumps(fallback.name) + ', "features": [\n'
            + ',\n'.join(json.dumps(f) for f in features) + '\n]}\n')
    return dst

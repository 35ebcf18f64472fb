"""Synthetic traces with known AR parameters, shared by the tests."""

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.model.geodesy import offset
from gps_error_ros.traces.trace_io import Trace, write_trace_csv

# Known parameters, not Table II's.
NORTH = AxisParams(0.3, (1.1, -0.25, 0.05), 0.6)
EAST = AxisParams(-0.1, (0.8,), 0.9)
TRUTH = (37.42, -122.08)


def synthetic_trace(n, seed=1, drop=()):
    model = ARErrorModel(NORTH, EAST)
    err = model.simulate(streams.agent_key(seed), n)[:, 0]
    t = np.arange(n, dtype=float)
    keep = np.setdiff1d(np.arange(n), np.asarray(drop, dtype=int))
    lat, lon = offset(TRUTH[0], TRUTH[1], err[keep, 0], err[keep, 1])
    ones = np.ones(keep.size)
    return Trace('synthetic', t[keep], lat, lon, TRUTH[0] * ones,
                 TRUTH[1] * ones), err[keep]


def write_csv(path, trace):
    """Write ``trace`` as a trace CSV (the package's one writer)."""
    return write_trace_csv(trace, path)


def gpx_file(path, points, extra=''):
    """Write a GPX 1.0 track of (iso time, lat, lon, ele) points."""
    body = ''.join(f'<trkpt lat="{la}" lon="{lo}"><ele>{el}</ele>'
                   + (f'<time>{t}</time>' if t else '') + f'{extra}</trkpt>'
                   for t, la, lo, el in points)
    path.write_text('<?xml version="1.0"?><gpx version="1.0" creator="test" '
                    'xmlns="http://www.topografix.com/GPX/1/0"><trk><trkseg>'
                    f'{body}</trkseg></trk></gpx>')
    return path


def write_drive(path, steps=1500):
    """Write a drive north-east, at 1 to 13 m/s (period 90 s), with turns."""
    t = np.arange(steps, dtype=float)
    speed = 7.0 + 6.0 * np.sin(2 * np.pi * t / 90.0)
    heading = np.radians(45.0 + 40.0 * np.sin(2 * np.pi * t / 400.0))
    lat, lon = np.empty(steps), np.empty(steps)
    lat[0], lon[0] = 37.4, -122.1
    for k in range(1, steps):
        lat[k], lon[k] = offset(lat[k - 1], lon[k - 1], speed[k] * np.cos(heading[k]),
                                speed[k] * np.sin(heading[k]))
    path.write_text('t,truth_lat,truth_lon\n' + ''.join(
        f'{a:g},{float(b)!r},{float(c)!r}\n' for a, b, c in zip(t, lat, lon)))

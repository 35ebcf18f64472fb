"""
Print what the measured traces say about fix availability (docs/availability.md).

For each trace CSV: its gaps on the 1 Hz grid (outages of 2 or more missing
steps, as ``gps_error calibrate`` counts them, and single dropped steps);
the error change across each gap beside the 2-step changes inside the trace
(does the error continue or jump after a gap?); and runs of repeated
identical positions (stale fixes), with the truth's and the phone's speed
at the repeated rows (a hold at a standstill, or stale fixes in motion?).

    python tools/outage_evidence.py [--data data]
"""

import argparse
from pathlib import Path
import sys

import numpy as np

from gps_error_ros.fit.calibration import errors_on_grid, estimate_availability
from gps_error_ros.model.availability import runs_without_fix
from gps_error_ros.model.geodesy import difference
from gps_error_ros.traces.trace_io import read_trace_csv

TRACES = ('gsdc2020-mtv1-pixel4.csv', 'gsdc2020-mtv1-pixel4xlmodded.csv',
          'urbannav-hk-tst-ublox-spp.csv', 'gmt-static-phone-2016-08-22.csv')


def describe(path):
    """Return the lines that describe one trace."""
    tr = read_trace_csv(path)
    grid = errors_on_grid(tr)
    fitted = estimate_availability(grid)
    section, ev = fitted.section, fitted.evidence
    lines = [f'{path.name}: {grid.n} fixes on the grid, {ev["outages"]} outage(s), '
             f'{ev["dropped_steps"]} dropped step(s)'
             + (f'; outage rate < {ev["outage_rate_upper_95"]:.2g} per step (95 %)'
                if section is None else f'; fitted {section}')]
    north, east = difference(tr.lat, tr.lon, tr.truth_lat, tr.truth_lon)
    err = np.stack([north, east], axis=1)
    step = np.rint(tr.t - tr.t[0]).astype(int)
    two = np.flatnonzero(step[2:] - step[:-2] == 2)
    typical = np.hypot(*(err[two + 2] - err[two]).T)
    for i in np.flatnonzero(np.diff(step) > 1):
        jump = float(np.hypot(*(err[i + 1] - err[i])))
        pct = 100.0 * np.mean(typical < jump)
        lines.append(f'  gap after t={tr.t[i]:g} s ({step[i + 1] - step[i] - 1} missing): '
                     f'error change {jump:.2f} m, percentile {pct:.0f} of the '
                     f'{typical.size} 2-step changes (median {np.median(typical):.2f} m)')
    same = np.r_[False, (np.diff(tr.lat) == 0) & (np.diff(tr.lon) == 0)]
    runs = runs_without_fix(~same)        # runs of repeats
    speed, truth_speed = tr.extra.get('speed'), tr.extra.get('truth_speed')
    text = f'  repeated positions: {int(same.sum())} rows in {len(runs)} run(s)'
    if runs:
        text += f' (longest {max(runs)} steps)'
        for name, v in (('truth speed', truth_speed), ('reported speed', speed)):
            if v is not None and np.isfinite(v[same]).any():
                text += f'; {name} at them <= {np.nanmax(v[same]):.2f} m/s'
    if truth_speed is not None:
        text += f'; rows with truth speed < 0.2 m/s: {int(np.sum(truth_speed < 0.2))}'
    lines.append(text)
    return lines


#: The repository's measured recordings (data/README.md).
DATA = Path(__file__).resolve().parents[1] / 'data'


def main(argv=None):
    """Print the evidence for every measured trace found; exit 0."""
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--data', default=str(DATA), help='folder of the trace CSVs')
    args = p.parse_args(argv)
    for name in TRACES:
        path = Path(args.data) / name
        if path.exists():
            print('\n'.join(describe(path)))
    return 0


if __name__ == '__main__':
    sys.exit(main())

"""
Speed and course of the velocity model against measured phones (docs/velocity.md).

For each trace with speed and course columns: fit the ``velocity`` section on
the first 70 % (``fit.velocity_fit``), simulate the phone's speed and course
``--sims`` times on the truth of the last 30 % (each run its own seed), and
set the measured held-out statistics beside the simulated median and central
95 % range, with the measured value's percentile: speed error RMS and bias on
moving rows (truth >= 1 m/s), course error RMS for 1-3, 3-10 and >= 10 m/s,
and the share of zero-speed reports at the reference's standstill; and the
same statistics of the truth's own chord with no error added (the floor
that ``simulate`` and the node, which take the true velocity from 1-s
chords of the truth's positions, cannot go below). Then, over the whole
trace, the lag at which the reference's course and speed best match the
phone's, per speed band, and the error's RMS across the track and along it
at those lags (:func:`best_lags`). Then the shape of the error along and
across the track by band, at the section's lags and bias fitted on the
whole trace (:func:`tails`). Last, on the rolling folds of ``compare
--folds``, what the section's speed lag alone adds to the open road's speed
error (:func:`lag_alone`).

    python tools/velocity_evidence.py [--data data] [--sims 200]
"""

import argparse
import dataclasses
from pathlib import Path
import sys

import numpy as np

from gps_error_ros.judge.generalise import rolling_splits
from gps_error_ros.judge.velocity_check import BANDS as FOLD_BANDS
from gps_error_ros.fit.validation import slice_trace
from gps_error_ros.fit.velocity_fit import estimate_velocity, residuals, SLOW_TRUTH, vectors
from gps_error_ros.model.motion_lag import truth_at
from gps_error_ros.model.velocity import velocity_from_dict
from gps_error_ros.sim.velocity_sim import speed_and_course
from gps_error_ros.traces.trace_io import read_trace_csv

TRACES = ('gsdc2020-mtv1-pixel4.csv', 'gsdc2020-mtv1-pixel4xlmodded.csv')
BANDS = ((1.0, 3.0), (3.0, 10.0), (10.0, 100.0))


def course_error(course, truth_course):
    """Return the signed course difference in degrees, in [-180, 180)."""
    return (course - truth_course + 180.0) % 360.0 - 180.0


def statistics(speed, course, truth_speed, truth_course):
    """Return the statistics compared (NaN where a band has no rows)."""
    out = {}
    moving = truth_speed >= 1.0
    err = speed[moving] - truth_speed[moving]
    out['speed error RMS (m/s)'] = float(np.sqrt(np.nanmean(err ** 2)))
    out['speed error mean (m/s)'] = float(np.nanmean(err))
    for lo, hi in BANDS:
        rows = (truth_speed >= lo) & (truth_speed < hi) & np.isfinite(course) \
            & np.isfinite(truth_course)
        d = course_error(course[rows], truth_course[rows])
        out[f'course error RMS {lo:g}-{hi:g} m/s (deg)'] = \
            float(np.sqrt(np.mean(d ** 2))) if rows.any() else float('nan')
    still = truth_speed < 0.2
    out['zero speed at standstill (share)'] = \
        float(np.mean(speed[still] == 0)) if still.any() else float('nan')
    return out


def best_lags(trace):
    """
    Return lines: per speed band, the lag that best matches the course, and the speed.

    Over the whole trace: the reference's course (unwrapped) and speed taken
    0, 0.1, .. 1 s earlier (linear in time); the course's lag is the one with
    the least median absolute course error, the speed's the one with the
    least SD of the speed error (the section's ``lag_s`` and ``course_lag_s``
    are fitted the same way over all bands at once).
    Across the track: the phone's speed times the sine of the course error
    at the course's lag (m/s), its RMS.
    """
    ex, t = trace.extra, trace.t
    ok = np.isfinite(ex['truth_speed']) & np.isfinite(ex['truth_bearing'])
    course = np.degrees(np.unwrap(np.radians(ex['truth_bearing'][ok])))
    out = []
    for lo, hi in ((1.0, 15.0), (15.0, 100.0)):
        rows = (ex['truth_speed'] >= lo) & (ex['truth_speed'] < hi) & np.isfinite(ex['bearing'])
        by_course, by_speed, across = {}, {}, {}
        for lag in np.round(np.arange(0.0, 1.01, 0.1), 1):
            past = t[rows] - lag
            d = course_error(ex['bearing'][rows], np.interp(past, t[ok], course) % 360.0)
            by_course[lag] = float(np.median(np.abs(d)))
            across[lag] = float(np.sqrt(np.mean((ex['speed'][rows]
                                                 * np.sin(np.radians(d))) ** 2)))
            by_speed[lag] = float(np.std(ex['speed'][rows]
                                         - np.interp(past, t[ok], ex['truth_speed'][ok])))
        c, v = min(by_course, key=by_course.get), min(by_speed, key=by_speed.get)
        out.append(f'  {lo:g}-{hi:g} m/s, {int(rows.sum())} rows: the course matches best '
                   f'{c:.1f} s later (median error {by_course[c]:.3f} deg; across the '
                   f'track RMS {across[c]:.3f} m/s), the speed {v:.1f} s later (error SD '
                   f'{by_speed[v]:.3f} m/s)')
    return out


def tails(trace):
    """
    Return lines: per speed band, how heavy-tailed the error is along and across the track.

    The section fitted on the whole trace gives the lags and the speed bias;
    the error left (the phone's velocity less the truth's at its lags, with
    the bias) is split along the truth's direction and across it. Per band
    of the true speed: its RMS, the median absolute deviation over the RMS
    (0.67 for a normal error) and the kurtosis (3 for a normal error). A
    small ratio and a large kurtosis: most rows err far less than the RMS
    says, a few far more.
    """
    section = estimate_velocity(trace).section
    moving, v_all, w_all = residuals(trace, section)
    speed = trace.extra['truth_speed'][moving]
    out = []
    for lo, hi in ((1.0, 15.0), (15.0, 100.0)):
        band = (speed >= lo) & (speed < hi)
        v_true, w = v_all[band], w_all[band]
        unit = v_true / np.hypot(v_true[:, 0], v_true[:, 1])[:, None]
        parts = {'along': np.sum(w * unit, axis=1),
                 'across': w[:, 0] * unit[:, 1] - w[:, 1] * unit[:, 0]}
        words = []
        for name, x in parts.items():
            x = x[np.isfinite(x)]
            rms = float(np.sqrt(np.mean(x ** 2)))
            mad = float(np.median(np.abs(x - np.median(x))))
            kurt = float(np.mean((x - x.mean()) ** 4) / np.var(x) ** 2)
            words.append(f'{name} RMS {rms:.3f} m/s, median deviation / RMS {mad / rms:.2f}, '
                         f'kurtosis {kurt:.1f}')
        out.append(f'  {lo:g}-{hi:g} m/s, {int(band.sum())} rows, the error\'s shape: '
                   + '; '.join(words))
    return out


def lag_alone(trace):
    """
    Return lines: per rolling fold, the open road's held-out speed error against the section's.

    The section is fitted on the fold's training rows (as ``compare --folds``
    does). On the held-out rows of the fastest band: the SD of the phone's
    speed error; the RMS of the section's SD at those rows' speeds; the SD
    of what the section's speed lag ``lag_s`` alone makes of the reference's
    own velocity (its speed ``lag_s`` earlier, less its speed now); and the
    two together, what a simulated speed error has.
    """
    lo_speed = FOLD_BANDS[-1][0]
    out = [f'  open road ({lo_speed:g}+ m/s) on the rolling folds: the phone\'s speed error '
           f'SD against the section\'s SD and its lag alone']
    for label, split in rolling_splits(trace):
        section = estimate_velocity(split.velocity[0]).section
        test = split.velocity[1]
        fast = test.extra['truth_speed'] >= lo_speed
        if section is None or fast.sum() < 2:
            continue
        v = vectors(test.extra['truth_speed'], test.extra['truth_bearing'],
                    zero_below=SLOW_TRUTH)
        known = np.isfinite(v).all(axis=1)
        past = truth_at(test.t[known], v[known], test.t - section['lag_s'])
        lag = float(np.std(np.hypot(*past[fast].T) - test.extra['truth_speed'][fast]))
        table = float(np.sqrt(np.mean(velocity_from_dict(section).sd_at(
            test.extra['truth_speed'][fast]) ** 2)))
        phone = float(np.std(test.extra['speed'][fast] - test.extra['truth_speed'][fast]))
        out.append(f'    {label}, {int(fast.sum())} rows: phone {phone:.3f} m/s; section '
                   f'SD {table:.3f}, its lag ({section["lag_s"]:.1f} s) alone {lag:.3f}, '
                   f'together {np.hypot(table, lag):.3f}')
    return out


def compare(path, sims):
    """Return the lines of one trace's comparison."""
    trace = read_trace_csv(path)
    fitted = estimate_velocity(slice_trace(trace, 0.0, 0.7))
    section, evidence = fitted.section, fitted.evidence
    if section is None:
        return [f'{path.name}: no velocity fit ({evidence["reason"]})']
    velocity = velocity_from_dict(section)
    test = slice_trace(trace, 0.7, 1.0)
    ex = test.extra
    measured = statistics(ex['speed'], ex['bearing'], ex['truth_speed'], ex['truth_bearing'])
    data = {'t': test.t, 'agent': [''] * len(test), 'truth_lat': test.truth_lat,
            'truth_lon': test.truth_lon}
    start = int(np.floor(test.t[0]))
    runs = []
    for seed in range(sims):
        speed, course, _, _ = speed_and_course(velocity, seed, data, start, 1.0)
        runs.append(statistics(speed, course, ex['truth_speed'], ex['truth_bearing']))
    lines = [f'{path.name}: fitted on the first 70 % {section}; held out {len(test)} rows, '
             f'{sims} simulations']
    for name, value in measured.items():
        sim = np.array([r[name] for r in runs])
        sim = sim[np.isfinite(sim)]
        if not np.isfinite(value) or not sim.size:
            lines.append(f'  {name}: measured {value:.3f}, simulated: none')
            continue
        lo, med, hi = np.percentile(sim, [2.5, 50, 97.5])
        pct = 100.0 * (np.mean(sim < value) + 0.5 * np.mean(sim == value))
        lines.append(f'  {name}: measured {value:.3f}, simulated median {med:.3f} '
                     f'(95 % {lo:.3f} to {hi:.3f}), percentile {pct:.0f}')
    # the truth's own chords at the lags, no error nor bias: simulate's true velocity alone
    still = dataclasses.replace(velocity, sigma=1e-12, sigma_by_speed=None, speed_bias=None)
    speed, course, _, _ = speed_and_course(still, 0, data, start, 1.0)
    floor = statistics(speed, course, ex['truth_speed'], ex['truth_bearing'])
    lines.append('  the truth\'s 1-s chord alone, no error added: ' + ', '.join(
        f'{name.split(" (")[0]} {value:.3f}' for name, value in floor.items()
        if 'standstill' not in name))
    return lines + best_lags(trace) + tails(trace) + lag_alone(trace)


#: The repository's measured recordings (data/README.md).
DATA = Path(__file__).resolve().parents[1] / 'data'


def main(argv=None):
    """Print the comparison for every trace found; exit 0."""
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--data', default=str(DATA), help='folder of the trace CSVs')
    p.add_argument('--sims', type=int, default=200, help='simulations per trace (200)')
    args = p.parse_args(argv)
    for name in TRACES:
        path = Path(args.data) / name
        if path.exists():
            print('\n'.join(compare(path, args.sims)))
    return 0


if __name__ == '__main__':
    sys.exit(main())

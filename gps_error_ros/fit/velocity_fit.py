"""
Fit a profile's ``velocity`` section from a trace's speed and course columns.

Needs ``speed``, ``bearing`` (the phone's) and ``truth_speed``,
``truth_bearing`` (the reference's), as the GSDC traces carry them. Rows
whose speed (the phone's or the reference's) is negative, not finite or
100 m/s or more, or whose course lies outside 0-360 degrees, are left out
(counted as ``implausible_rows``). Both are
turned into east/north velocity vectors (a course missing where the speed is
0 is a zero vector; where the reference is slower than 0.2 m/s its course is
missing and its vector taken as zero). Then, on the rows where the reference
moves at 1 m/s or more and the phone reports a course:

* ``lag_s``: the delay in 0, 0.1, .. 1.0 s for which the phone's speed
  errs least (least SD of the speed error) against the reference's that
  much earlier (linear interpolation of the reference's vectors in time,
  never back across a gap between joined recordings);
* ``course_lag_s``: the delay in the same steps for which the phone's
  velocity is nearest (least RMS) to one with the reference's speed
  ``lag_s`` earlier and its direction that much earlier;
* ``speed_bias``: per band of the reference's speed (as ``sigma_by_speed``
  below, at the band's median speed; one band at least), the mean of the
  phone's velocity less the truth's at those lags, along the truth's
  direction (not the mean speed error, which the error across the track
  raises by about ``sigma^2 / (2 speed)``);
* ``sigma``: at those lags and with that bias, the RMS of the remaining
  error's east and north components (pooled); ``phi``: its lag-1
  autocorrelation on consecutive 1-s rows (pooled over both components);
* ``sigma_by_speed``: the same RMS per band of the reference's speed
  (:data:`SPEED_EDGES`; a band with fewer than :data:`BAND_ROWS` rows joins
  the next faster one, the fastest joins the one before), at the band's
  median speed; written where two bands or more are left. ``phi`` is then
  of the error divided by the SD at its speed;
* ``standstill``: the reference speed (up to 2 m/s) at or below which the
  phone reported exactly 0 with the fewest exceptions either way (at least
  10 zero reports; else 0); the phone reports 0 at or below it.

* ``scale_sd_log``: how the error's scale moves between stretches
  (:func:`block_scale`): the SD over 300-s blocks of the log RMS of the
  error in units of its SD at its speed, less what sampling alone gives a
  block of that many rows (in variance); written where enough blocks had
  enough rows and something lies beyond sampling. The section draws each
  agent's scale from it (:class:`~gps_error_ros.model.velocity.Velocity`);
  the sampling of a block's log RMS is that of an error with the kurtosis
  measured within the blocks (each block's rows in units of its own RMS);
* ``burst_share`` and ``burst_ratio`` (:func:`fit_bursts`): where the error
  in units of its SD is heavy-tailed (kurtosis above :data:`NORMAL_KURTOSIS`),
  the two-scale normal mixture with the error's variance, median absolute
  value and kurtosis.
"""

import math
from typing import Any, Optional, Sequence

import numpy as np
from scipy import optimize

from gps_error_ros.fit.population_fit import block_ids, BLOCK_S, MIN_BLOCK_SAMPLES, MIN_BLOCKS
from gps_error_ros.fit.section_fit import SectionFit
from gps_error_ros.model.motion_lag import RUN_GAP_S, truth_at
from gps_error_ros.model.state import BoolArray, FloatArray, Numbers
from gps_error_ros.model.velocity import (MAX_BURST_RATIO, MAX_BURST_SHARE, sd_from_table,
                                          speed_along, with_speed_bias)
from gps_error_ros.traces.trace_io import Trace

NEEDED = ('speed', 'bearing', 'truth_speed', 'truth_bearing')
MOVING = 1.0          # m/s: rows used for sigma, phi and the lag
SLOW_TRUTH = 0.2      # m/s: below it the reference's course is missing and its vector 0
LAGS = np.round(np.arange(0.0, 1.01, 0.1), 1)
#: m/s: edges of the speed bands ``sigma_by_speed`` is fitted on (walking, town, open road).
SPEED_EDGES = (1.0, 2.5, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0, np.inf)
#: m/s: a speed at or above it is not a walker's or a car's (that row is left out).
MAX_SPEED = 100.0
#: Moving rows a speed band needs; fewer join the next band.
BAND_ROWS = 30
#: Kurtosis at or below which the error is taken as normal (no bursts).
NORMAL_KURTOSIS = 3.5


def vectors(speed: Numbers, course_deg: Numbers, zero_below: float = 0.0) -> FloatArray:
    """Turn speeds and courses into east/north rows; no course at a low speed is 0."""
    speed = np.asarray(speed, dtype=float)
    c = np.radians(np.asarray(course_deg, dtype=float))
    v = np.stack([speed * np.sin(c), speed * np.cos(c)], axis=1)
    small = ~np.isfinite(c) & np.isfinite(speed) & (speed <= zero_below)
    v[small] = 0.0
    return v


def _plausible(speed: FloatArray, course: FloatArray) -> BoolArray:
    """Return rows whose speed is in [0, MAX_SPEED) m/s and course, where given, in [0, 360]."""
    speed, course = np.asarray(speed, dtype=float), np.asarray(course, dtype=float)
    with np.errstate(invalid='ignore'):
        return ((speed >= 0.0) & (speed < MAX_SPEED)
                & (np.isnan(course) | ((course >= 0.0) & (course <= 360.0))))


def speed_bands(speed: FloatArray, edges: Sequence[float] = SPEED_EDGES,
                least: int = BAND_ROWS) -> list[BoolArray]:
    """
    Return the rows of each band of ``speed``, as index arrays, slowest first.

    A band with fewer than ``least`` rows joins the next faster one; a last
    band still short joins the one before it. Rows outside the edges are left out.
    """
    speed = np.asarray(speed, dtype=float)
    bands, rows = [], np.zeros(0, dtype=np.int64)
    for lo, hi in zip(edges[:-1], edges[1:]):
        rows = np.r_[rows, np.flatnonzero((speed >= lo) & (speed < hi))]
        if rows.size >= least:
            bands.append(rows)
            rows = np.zeros(0, dtype=np.int64)
    if rows.size:
        if bands:
            bands[-1] = np.r_[bands[-1], rows]
        else:
            bands.append(rows)
    return bands


def _by_speed(w: FloatArray, speed: FloatArray) -> Optional[tuple[tuple[float, float], ...]]:
    """Return ((median speed, RMS of the components), ...) per band, or None below two."""
    bands = speed_bands(speed)
    if len(bands) < 2:
        return None
    return tuple((round(float(np.median(speed[b])), 3),
                  round(max(float(np.sqrt(np.mean(w[b] ** 2))), 1e-4), 6)) for b in bands)


def _speed_bias(d: FloatArray, speed: FloatArray) -> tuple[tuple[float, float], ...]:
    """Return ((median speed, mean error along the track), ...) per band of ``speed``."""
    return tuple((round(float(np.median(speed[b])), 3), round(float(np.mean(d[b])), 6))
                 for b in speed_bands(speed))


def _standstill(truth_speed: FloatArray, zero: BoolArray) -> float:
    """Return the true speed at or below which the phone's zero reports are best told."""
    ok = np.isfinite(truth_speed)
    ts, z = truth_speed[ok], zero[ok]
    candidates = np.unique(np.r_[0.0, ts[(ts >= 0.0) & (ts <= 2.0)]])
    wrong = [np.sum(z & (ts > c)) + np.sum(~z & (ts <= c)) for c in candidates]
    return float(candidates[int(np.argmin(wrong))])


def fit_bursts(u: FloatArray) -> Optional[tuple[float, float]]:
    """
    Return ``(burst_share, burst_ratio)`` of the error ``u`` (rows, both components), or None.

    The normal mixture ``N(0, s1^2)`` on a share ``1 - p`` and ``N(0,
    s2^2)`` on ``p``, of the variance of ``u``, whose median absolute value
    over the RMS and kurtosis are those of ``u``; ``burst_ratio`` is ``s2 /
    s1``. None where ``u`` is near normal (kurtosis at or below
    :data:`NORMAL_KURTOSIS`), has fewer than 60 values, or no mixture in
    the model's bounds matches.
    """
    x = np.asarray(u, dtype=float).ravel()
    x = x[np.isfinite(x)]
    if x.size < 60:
        return None
    x = x / math.sqrt(float(np.mean(x ** 2)))
    median, kurt = float(np.median(np.abs(x))), float(np.mean(x ** 4))
    if kurt <= NORMAL_KURTOSIS:
        return None

    def misfit(v: FloatArray) -> list[float]:
        p, s1 = 1.0 / (1.0 + math.exp(-v[0])), math.exp(v[1])
        s2sq = (1.0 - (1.0 - p) * s1 * s1) / p
        if s2sq <= s1 * s1:
            return [10.0, 10.0]
        s2 = math.sqrt(s2sq)
        half = optimize.brentq(lambda a: (1 - p) * math.erf(a / s1 / math.sqrt(2))
                               + p * math.erf(a / s2 / math.sqrt(2)) - 0.5, 1e-9, 100.0)
        return [half - median, math.log(3.0 * ((1 - p) * s1 ** 4 + p * s2 ** 4) / kurt)]

    best = min((optimize.least_squares(misfit, [math.log(p0 / (1 - p0)), math.log(s0)])
                for p0 in (0.02, 0.05, 0.1, 0.2) for s0 in (0.4, 0.6, 0.8)),
               key=lambda sol: sol.cost)
    p, s1 = 1.0 / (1.0 + math.exp(-best.x[0])), math.exp(best.x[1])
    ratio = math.sqrt((1.0 - (1.0 - p) * s1 * s1) / p) / s1
    return None if best.cost > 1e-6 else bursts_as_written(p, ratio)


def bursts_as_written(p: float, ratio: float) -> Optional[tuple[float, float]]:
    """
    Return ``(burst_share, burst_ratio)`` as a profile writes them, or None outside its bounds.

    Checked after the rounding: a share of a few millionths rounds to 0, which
    the profile schema refuses (found by the calibration fuzz test).
    """
    p, ratio = round(p, 5), round(ratio, 4)
    if not (0.0 < p <= MAX_BURST_SHARE and 1.0 < ratio <= MAX_BURST_RATIO):
        return None
    return p, ratio


def block_scale(u: FloatArray, t: FloatArray, phi: float,
                block_s: float = BLOCK_S) -> Optional[dict[str, Any]]:
    """
    Return how the error's scale spreads between blocks, or None with too few blocks.

    ``u``: the error's east/north rows in units of its SD at their speed
    (NaN where not judged); ``t``: their times, s; ``phi``: its lag-1
    autocorrelation. Blocks are the population fit's (``block_s`` from each
    run's start); a block counts with :data:`MIN_BLOCK_SAMPLES` judged rows
    or more, and :data:`MIN_BLOCKS` must. Each block's log RMS over both
    components: their SD over the blocks, the SD that sampling alone gives
    one (``sqrt((1 + phi^2) / (1 - phi^2) / (4 n))`` for ``n`` rows of a
    normal error, averaged over the blocks in variance, and times ``sqrt((k
    - 1) / 2)`` for the kurtosis ``k`` within the blocks, each block in
    units of its own RMS: a heavy-tailed error's RMS varies more), and what
    lies beyond, ``sqrt(max(0, SD^2 - sampling^2))``: the log SD of a scale
    drawn per stretch.
    """
    ok = np.isfinite(u).all(axis=1)
    if ok.sum() < MIN_BLOCK_SAMPLES * MIN_BLOCKS:
        return None
    judged = u[ok]
    ids = block_ids([np.asarray(t, dtype=float)[ok]], block_s)[0]
    logs, sizes, within = [], [], []
    for b in np.unique(ids):
        x = judged[ids == b]
        if len(x) >= MIN_BLOCK_SAMPLES:
            square = float(np.mean(x ** 2))
            logs.append(0.5 * np.log(square))
            sizes.append(len(x))
            within.append(x / math.sqrt(square))
    if len(logs) < MIN_BLOCKS:
        return None
    spread = float(np.var(logs, ddof=1))
    kurt = float(np.mean(np.concatenate(within) ** 4))      # 3 for a normal error
    sampling = float(np.mean((1.0 + phi ** 2) / (1.0 - phi ** 2) / (4.0 * np.array(sizes))))
    sampling *= max(kurt - 1.0, 2.0) / 2.0
    return {'blocks': len(logs), 'block_log_rms_sd': round(math.sqrt(spread), 4),
            'kurtosis_within': round(kurt, 2), 'sampling_sd': round(math.sqrt(sampling), 4),
            'beyond_sampling_sd': round(math.sqrt(max(0.0, spread - sampling)), 4)}


def _section(sigma: float, phi: float, lag: float, course_lag: float, standstill: float,
             bias: tuple[tuple[float, float], ...],
             table: Optional[tuple[tuple[float, float], ...]],
             between: Optional[dict[str, Any]]) -> dict[str, Any]:
    """Return the fitted ``velocity`` section as plain data (see the module doc)."""
    section: dict[str, Any] = {'sigma': round(sigma, 6), 'phi': round(phi, 6),
                               'lag_s': float(lag), 'standstill': round(standstill, 4),
                               'course_lag_s': float(course_lag),
                               'speed_bias': [list(node) for node in bias]}
    if table is not None:
        section['sigma_by_speed'] = [list(node) for node in table]
    if between is not None and between['beyond_sampling_sd'] > 0.0:
        section['scale_sd_log'] = between['beyond_sampling_sd']
    return section


def _velocities(trace: Trace) -> tuple[FloatArray, FloatArray, Any, Any, BoolArray]:
    """
    Return (the phone's vectors, the truth's, rows with the truth, moving rows, implausible rows).

    The vectors are (n, 2) east/north m/s, NaN on the implausible rows; the
    moving rows have both vectors and the truth at :data:`MOVING` or more.
    """
    ex = trace.extra
    odd = ~(_plausible(ex['speed'], ex['bearing'])
            & _plausible(ex['truth_speed'], ex['truth_bearing']))
    phone = vectors(ex['speed'], ex['bearing'], zero_below=0.0)
    truth = vectors(ex['truth_speed'], ex['truth_bearing'], zero_below=SLOW_TRUTH)
    phone[odd] = truth[odd] = np.nan
    known = np.isfinite(truth).all(axis=1)
    rows = known & np.isfinite(phone).all(axis=1) & (ex['truth_speed'] >= MOVING)
    return phone, truth, known, rows, odd


def residuals(trace: Trace, section: dict[str, Any]) -> tuple[BoolArray, FloatArray, FloatArray]:
    """
    Return (the moving rows (n,), the truth there (m, 2), the error left (m, 2)) under ``section``.

    The truth is taken at the section's lags (its speed ``lag_s`` earlier,
    its direction ``course_lag_s`` earlier); the error left is the phone's
    velocity less that truth with the section's speed bias, east/north
    m/s: what the fit measures its SD, persistence and tails on.
    """
    phone, truth, known, rows, _ = _velocities(trace)
    t = trace.t
    v_true = speed_along(*(truth_at(t[known], truth[known], t[rows] - section[k], RUN_GAP_S)
                           for k in ('lag_s', 'course_lag_s')))
    return rows, v_true, phone[rows] - with_speed_bias(v_true, section['speed_bias'])


def estimate_velocity(trace: Trace) -> SectionFit:
    """Return the velocity section (or why none) for ``trace`` (see module doc)."""
    missing = [k for k in NEEDED if k not in trace.extra]
    if missing:
        return SectionFit(None, {'fitted': False, 'reason': f'no column(s) {missing}'})
    ex = trace.extra
    phone, truth, known, rows, odd = _velocities(trace)
    if rows.sum() < 30 or known.sum() < 2:
        return SectionFit(None, {'fitted': False,
                                 'reason': f'{int(rows.sum())} moving rows with both '
                                           f'velocities (30 needed)',
                                 'implausible_rows': int(odd.sum())})
    t = trace.t                 # the truth earlier, never reaching back into the recording before
    past = {float(lag): truth_at(t[known], truth[known], t[rows] - lag, RUN_GAP_S)
            for lag in LAGS}
    speed = np.hypot(phone[rows, 0], phone[rows, 1])
    speed_sd = {lag: float(np.std(speed - np.hypot(v[:, 0], v[:, 1]))) for lag, v in past.items()}
    lag = min(speed_sd, key=lambda k: speed_sd[k])
    left = {c: phone[rows] - speed_along(past[lag], v) for c, v in past.items()}
    rms = {c: float(np.sqrt(np.mean(d ** 2))) for c, d in left.items()}
    course_lag = min(rms, key=lambda k: rms[k])
    v_true = speed_along(past[lag], past[course_lag])
    along = v_true / np.maximum(np.hypot(v_true[:, 0], v_true[:, 1]), 1e-9)[:, None]
    bias = _speed_bias(np.sum((phone[rows] - v_true) * along, axis=1), ex['truth_speed'][rows])
    w = np.full_like(phone, np.nan)
    w[rows] = phone[rows] - with_speed_bias(v_true, bias)
    pair = np.flatnonzero(rows[:-1] & rows[1:] & (np.diff(t) == 1.0))
    sigma = float(np.sqrt(np.mean(w[rows] ** 2)))
    table = _by_speed(w[rows], ex['truth_speed'][rows])
    u = w.copy()                # the error in units of its SD at its speed
    if table is not None:
        u[rows] = w[rows] / sd_from_table(table, ex['truth_speed'][rows])[:, None]
    phi = float(np.sum(u[pair] * u[pair + 1]) / np.sum(u[pair] ** 2)) if pair.size else 0.0
    phi = min(max(phi, -0.99), 0.99)
    sds = [sigma] + ([sd for _, sd in table] if table is not None else [])
    if not all(0.0 < sd < MAX_SPEED for sd in sds):
        return SectionFit(None, {'fitted': False, 'implausible_rows': int(odd.sum()),
                                 'reason': f'the error\'s RMS {max(sds):.4g} m/s lies '
                                           f'outside (0, {MAX_SPEED:g}) m/s'})
    zero = ex['speed'] == 0
    standstill = _standstill(np.where(odd, np.nan, ex['truth_speed']), zero) \
        if zero.sum() >= 10 else 0.0
    between = block_scale(u, t, phi)
    section = _section(sigma, phi, lag, course_lag, standstill, bias, table, between)
    bursts = fit_bursts(u[rows])
    if bursts is not None:
        section['burst_share'], section['burst_ratio'] = bursts
    evidence = {'fitted': True, 'moving_rows': int(rows.sum()), 'pairs': int(pair.size),
                'speed_sd_by_lag_s': {f'{k:.1f}': round(v, 4) for k, v in speed_sd.items()},
                'rms_by_course_lag_s': {f'{k:.1f}': round(v, 4) for k, v in rms.items()},
                'mean_error_east_north': [round(float(np.mean(w[rows, a])), 4)
                                          for a in range(2)],
                'zero_speed_rows': int(zero.sum()), 'implausible_rows': int(odd.sum()),
                'scale_between_blocks': between}
    return SectionFit(section, evidence)

"""
Synthetic pedestrian walks whose errors carry an effect nobody declares.

For testing ``gps_error diagnose`` blind. A walker crosses Manhattan's grid
at 1 Hz (turns, waits at crossings; :mod:`walker`), and a phone reports its
position with an error: an AR(3) process (DS5-like persistence, innovation
SD 1.5 m, a bias) plus, per *scenario*, one effect made by a mechanism that
deliberately differs from the forms the diagnosis fits:

==================  =========================================================
scenario            mechanism (expected attribution)
==================  =========================================================
none                the AR(3) alone (nothing)
ar5                 an AR(5) process instead: effect-free, misspecified order
quantised           reported lat/lon rounded to 1e-6 degrees (~0.1 m; nothing)
street_ellipse      innovations elongated along the avenues (the grid's
                    canyons): 2:1 while walking an avenue, 1.5:1 on cross
                    streets (cross_axis_coupling)
receiver_latency    the receiver reports the position of 1.5-3 s ago (the
                    latency wanders with processing load) through a light
                    2-tap smoothing (motion_lag)
multipath           sporadic jumps: with probability 3 % a step's
                    innovation gets an extra N(0, 4^2) kick (heavy_tails)
canyon_levels       innovation SD switches among three levels (1x, 1.8x,
                    3x) with dwell times of about 2 min (variance_regimes)
canyon_gradual      innovation SD drifts smoothly, x exp(0.5 sin(2 pi t /
                    600 s)) (variance_regimes)
street_canyon       innovations along and across the street being walked,
                    across 2.5x along on avenues and 1.8x on cross streets
                    (same total variance); the frame is the street's axis,
                    not the direction of travel, and holds while waiting
                    at a corner; the walker turns at half the corners, not
                    a quarter (street_frame)
periodic            a 16 s sine of 4 m (north) and 3.5 m (east) added to the
                    reported error, not to the innovations (periodic)
engine_cycle        a position engine that refreshes every 8 s: the refresh
                    step's innovation 2.5x, the next 1.3x, the other six
                    0.8x; the cycle's start at random (periodic; the shape
                    is a burst, not a sine)
drifting_wave       the sine of ``periodic`` with its period drifting from
                    12 s to 20 s over the walk: no fixed cycle (outside the
                    list: ``unexplained``); east a quarter period behind
                    north, so the wave adds no north-east correlation (with
                    both phases at random it did, by the cosine of their
                    difference: coupling, which is in the list)
reflections         a reflected signal caught for 1-6 fixes (uniform, not
                    geometric) about 3 % of the time: the reported fix
                    sits 8-25 m (uniform) away, across the street walked,
                    and wanders by 1 m a fix while caught; added to the
                    reported error, so it does not persist (outliers)
==================  =========================================================

A pair ``a+b`` has both mechanisms at once (and should be attributed both).

Every walk has the fix stamps jittered by up to 50 ms, 0.5 % of fixes
dropped at random and one 30 s outage, so segments and gaps are exercised.
"""

from collections.abc import Collection

import numpy as np
from scipy import signal

from gps_error_ros.model.geodesy import offset
from gps_error_ros.model.state import BoolArray, FloatArray
from gps_error_ros.sim.walker import GRID_BEARING_DEG, MANHATTAN_DATUM, manhattan_walk
from gps_error_ros.traces.trace_io import Trace

#: scenario -> (effects the diagnosis should find, structure left unexplained)
SCENARIOS = {
    'none': ((), False),
    'ar5': ((), False),
    'quantised': ((), False),
    'street_ellipse': (('cross_axis_coupling',), False),
    'receiver_latency': (('motion_lag',), False),
    'multipath': (('heavy_tails',), False),
    'canyon_levels': (('variance_regimes',), False),
    'canyon_gradual': (('variance_regimes',), False),
    'street_canyon': (('street_frame',), False),
    'periodic': (('periodic',), False),
    'engine_cycle': (('periodic',), False),
    'drifting_wave': ((), True),
    'reflections': (('outliers',), False),
    # pairs: two mechanisms at once, each to be found
    'reflections+multipath': (('heavy_tails', 'outliers'), False),
    'engine_cycle+reflections': (('outliers', 'periodic'), False),
    'receiver_latency+street_ellipse': (('cross_axis_coupling', 'motion_lag'), False),
    'canyon_levels+receiver_latency': (('motion_lag', 'variance_regimes'), False),
    'periodic+street_canyon': (('periodic', 'street_frame'), False),
}
EFFECT_FREE = ('none', 'ar5', 'quantised')
#: the scenarios of two mechanisms (``make diagnose-long`` runs them; the
#: test suite's one-seed subset runs the others)
PAIRS = tuple(name for name in SCENARIOS if '+' in name)
#: each scenario's own random stream, fixed so that adding a scenario
#: leaves every other scenario's walks as they were
STREAM = {'ar5': 0, 'canyon_gradual': 1, 'canyon_levels': 2, 'drifting_wave': 3,
          'engine_cycle': 4, 'multipath': 5, 'none': 6, 'periodic': 7, 'quantised': 8,
          'receiver_latency': 9, 'street_canyon': 10, 'street_ellipse': 11,
          'reflections': 12, 'reflections+multipath': 13, 'engine_cycle+reflections': 14,
          'receiver_latency+street_ellipse': 15, 'canyon_levels+receiver_latency': 16,
          'periodic+street_canyon': 17}

PHI3 = (1.18, -0.06, -0.14)
PHI5 = (1.05, 0.05, -0.02, -0.18, 0.05)
SIGMA_W = 1.5
BIAS = (2.0, -1.0)
#: reflections: how far the reflected fix drifts per fix while caught, m (SD per axis)
WANDER_M = 1.0


def _innovations(parts: Collection[str], n: int, rng: np.random.Generator,
                 heading_avenue: BoolArray) -> FloatArray:
    w = rng.standard_normal((n, 2)) * SIGMA_W
    if 'street_ellipse' in parts:
        b = np.radians(GRID_BEARING_DEG)
        along = np.array([np.cos(b), np.sin(b)])        # (north, east)
        across = np.array([-np.sin(b), np.cos(b)])
        z = rng.standard_normal((n, 2))
        # 2:1 on avenues, 1.5:1 on cross streets, same total variance
        sa = np.where(heading_avenue, 2.0 / np.sqrt(2.5), 1.5 / np.sqrt(1.625))
        sc = np.where(heading_avenue, 1.0 / np.sqrt(2.5), 1.0 / np.sqrt(1.625))
        sa, sc = sa * SIGMA_W, sc * SIGMA_W
        w = (z[:, :1] * sa[:, None]) * along + (z[:, 1:] * sc[:, None]) * across
    elif 'street_canyon' in parts:
        b = np.radians(GRID_BEARING_DEG)
        axis = np.where(heading_avenue, b, b + np.pi / 2)   # the street walked
        along = np.stack([np.cos(axis), np.sin(axis)], axis=1)
        across = np.stack([-np.sin(axis), np.cos(axis)], axis=1)
        # deeper canyons on the avenues: across 2.5x along there, 1.8x on cross
        # streets; the same total variance
        ratio = np.where(heading_avenue, 2.5, 1.8)
        sa = SIGMA_W * np.sqrt(2.0 / (1.0 + ratio ** 2))
        z = rng.standard_normal((n, 2))
        w = (z[:, :1] * sa[:, None]) * along + (z[:, 1:] * (ratio * sa)[:, None]) * across
    if 'multipath' in parts:
        jump = rng.random(n) < 0.03
        w[jump] += rng.standard_normal((int(jump.sum()), 2)) * 4.0
    if 'canyon_levels' in parts:
        levels = np.array([1.0, 1.8, 3.0])
        scale = np.empty(n)
        i, lv = 0, int(rng.integers(3))
        while i < n:
            dwell = int(rng.exponential(120.0)) + 10
            scale[i:i + dwell] = levels[lv]
            lv = int(rng.choice([k for k in range(3) if k != lv]))
            i += dwell
        w *= scale[:, None] / np.sqrt(np.mean(levels ** 2))
    if 'engine_cycle' in parts:
        shape = np.array([2.5, 1.3] + [0.8] * 6)
        scale = shape[(np.arange(n) + int(rng.integers(8))) % 8]
        w *= scale[:, None] / np.sqrt(np.mean(shape ** 2))
    if 'canyon_gradual' in parts:
        t = np.arange(n)
        scale = np.exp(0.5 * np.sin(2 * np.pi * t / 600.0 + rng.uniform(0, 6.3)))
        w *= scale[:, None] / np.sqrt(np.mean(scale ** 2))
    return w


def _on_avenue(east: FloatArray, north: FloatArray, hold: bool = False) -> BoolArray:
    """
    Return, per sample, whether the walker heads along an avenue (the grid's bearing).

    ``hold``: while waiting at a corner the last street walked holds.
    """
    de, dn = np.gradient(east), np.gradient(north)
    b = np.radians(GRID_BEARING_DEG)
    avenue = np.abs(de * np.sin(b) + dn * np.cos(b)) > \
        np.abs(-de * np.cos(b) + dn * np.sin(b))
    if hold:
        moving = np.hypot(de, dn) > 0.3
        avenue = avenue[np.maximum.accumulate(np.where(moving, np.arange(avenue.size), 0))]
    return avenue


def _add_wave(parts: Collection[str], err: FloatArray, t: FloatArray, duration: int,
              rng: np.random.Generator) -> None:
    """Add the sine of ``periodic`` (or ``drifting_wave``) to the reported error, in place."""
    if 'periodic' not in parts and 'drifting_wave' not in parts:
        return
    ph = rng.uniform(0, 2 * np.pi, 2)
    if 'periodic' in parts:
        cycles = t / 16.0
    else:               # the period drifts from 12 s to 20 s over the walk
        period = 12.0 + 8.0 * t / duration
        cycles = np.cumsum(1.0 / period)
        ph[1] = ph[0] - 0.5 * np.pi     # in quadrature: no lag-0 correlation
    amp = (4.0, 3.5)
    err[:, 0] += amp[0] * np.sin(2 * np.pi * cycles + ph[0])
    err[:, 1] += amp[1] * np.sin(2 * np.pi * cycles + ph[1])


def _add_reflections(parts: Collection[str], err: FloatArray, avenue: BoolArray,
                     rng: np.random.Generator) -> None:
    """Add the jumps of ``reflections`` to the reported error, in place."""
    if 'reflections' not in parts:
        return
    n, k = len(err), 0
    b = np.radians(GRID_BEARING_DEG)
    while True:
        k += int(rng.geometric(0.008))        # about 1 in 125 steps starts one
        if k >= n:
            return
        length = int(rng.integers(1, 7))
        axis = b + np.pi / 2 if avenue[k] else b        # across the street walked
        size = rng.uniform(8.0, 25.0) * rng.choice([-1.0, 1.0])
        wander = np.cumsum(rng.normal(0.0, WANDER_M, (length, 2)), axis=0)
        stop = min(n, k + length)
        err[k:stop] += size * np.array([np.cos(axis), np.sin(axis)]) + wander[:stop - k]
        k = stop


def _reported_track(parts: Collection[str], north: FloatArray, east: FloatArray,
                    t: FloatArray, duration: int,
                    rng: np.random.Generator) -> tuple[FloatArray, FloatArray]:
    """Return the (north, east) track the receiver reports before its error."""
    rep_n, rep_e = north.copy(), east.copy()
    if 'receiver_latency' in parts:
        # latency wandering between 1.5 and 3 s (processing load), plus a
        # light 2-tap smoothing of the reported track
        lat_s = np.clip(2.2 + np.cumsum(rng.normal(0, 0.05, duration)), 1.5, 3.0)
        rep_n = np.interp(t - lat_s, t, north)
        rep_e = np.interp(t - lat_s, t, east)
        rep_n[1:] = 0.7 * rep_n[1:] + 0.3 * rep_n[:-1]
        rep_e[1:] = 0.7 * rep_e[1:] + 0.3 * rep_e[:-1]
    return rep_n, rep_e


def synthetic_trace(scenario: str, seed: int, duration: int = 3600) -> Trace:
    """
    Return a :class:`Trace` of a synthetic walk with ``scenario``'s effect.

    Deterministic in (scenario, seed, duration).
    """
    if scenario not in SCENARIOS:
        raise ValueError(f'unknown scenario {scenario!r}: expected one of '
                         f'{list(SCENARIOS)}')
    duration = int(duration)
    if duration < 60:
        raise ValueError(f'duration must be >= 60 s, got {duration}')
    rng = np.random.default_rng([seed, STREAM[scenario]])
    parts = scenario.split('+')
    # the street-frame scenario is a walk that turns corners: every other one
    walk = manhattan_walk(duration + 10, rng,
                          turn_probability=0.5 if 'street_canyon' in parts else 0.25)
    t = np.arange(duration, dtype=float)
    east, north = walk.position(t)
    avenue = _on_avenue(east, north, hold='street_canyon' in parts)
    burn = 600
    n = duration + burn
    w = _innovations(parts, n, rng, np.r_[np.zeros(burn, bool), avenue])
    phi = PHI5 if 'ar5' in parts else PHI3
    a = np.r_[1.0, -np.asarray(phi)]
    err = np.stack([signal.lfilter([1.0], a, w[:, k]) for k in range(2)],
                   axis=1)[burn:]
    err += BIAS
    _add_wave(parts, err, t, duration, rng)
    _add_reflections(parts, err, avenue, rng)
    rep_n, rep_e = _reported_track(parts, north, east, t, duration, rng)
    lat0, lon0 = MANHATTAN_DATUM[0], MANHATTAN_DATUM[1]
    truth_lat, truth_lon = offset(lat0, lon0, north, east)
    lat, lon = offset(lat0, lon0, rep_n + err[:, 0], rep_e + err[:, 1])
    if 'quantised' in parts:
        lat, lon = np.round(lat, 6), np.round(lon, 6)
    stamp = t + rng.uniform(-0.05, 0.05, duration)
    keep = rng.random(duration) >= 0.005
    gap = int(rng.integers(duration // 4, 3 * duration // 4))
    keep[gap:gap + 30] = False
    keep[0] = True
    speed = walk.speed(t)
    return Trace(name=f'synthetic-{scenario}-{seed}.csv', t=stamp[keep],
                 lat=np.asarray(lat)[keep], lon=np.asarray(lon)[keep],
                 truth_lat=np.asarray(truth_lat)[keep],
                 truth_lon=np.asarray(truth_lon)[keep],
                 extra={'speed': speed[keep]})

"""
Telling street_frame from cross_axis_coupling.

The travel-frame test keeps its level when the covariance is fixed in
north/east axes (also under persistent variance), has no power when the
direction never changes, and finds an ellipse that turns with the walker;
``diagnose`` then says which frame and why.
"""

import math

import numpy as np
from scipy import signal

from gps_error_ros.diagnose import diagnose
from gps_error_ros.diagnose.family import innovation_tests, travel_frame_test
from gps_error_ros.diagnose.mean import to_travel_frame
from gps_error_ros.diagnose.models import fit_model
from gps_error_ros.diagnose.pipeline import fit_base, run_family, split_step
from gps_error_ros.model.geodesy import offset
from gps_error_ros.sim.synthetic import synthetic_trace
from gps_error_ros.sim.walker import GRID_BEARING_DEG, MANHATTAN_DATUM, manhattan_walk
from gps_error_ros.traces.trace_io import Trace


def walk_headings(rng, n=2400):
    """Return the directions of travel of a Manhattan walk, 1 Hz."""
    w = manhattan_walk(n + 10, rng)
    east, north = w.position(np.arange(n, dtype=float))
    h = np.arctan2(np.gradient(east), np.gradient(north))
    moving = np.hypot(np.gradient(east), np.gradient(north)) > 0.1
    last = np.maximum.accumulate(np.where(moving, np.arange(n), 0))
    return h[last]


def test_level_with_fixed_axes_and_persistent_variance():
    """
    200 walks with a fixed, coupled covariance whose scale switches slowly.

    The share of p-values at or below 0.05 stays within the binomial 99 %
    bound of 5 % of 200 (at most 18).
    """
    rng = np.random.default_rng(4)
    cov = np.array([[4.0, 1.2], [1.2, 1.0]])
    chol = np.linalg.cholesky(cov)
    small = 0
    for _ in range(200):
        h = walk_headings(rng)
        scale = np.repeat(rng.choice([1.0, 2.5], size=h.size // 100 + 1), 100)[:h.size]
        r = (rng.standard_normal((h.size, 2)) @ chol.T) * scale[:, None]
        small += travel_frame_test(r, h).p_value <= 0.05
    assert small <= 18, small


def test_no_power_without_turns_and_power_with_them():
    rng = np.random.default_rng(5)
    n = 2400
    h = walk_headings(rng, n)
    c, s = np.cos(h), np.sin(h)
    z = rng.standard_normal((n, 2)) * [0.6, 1.5]            # along, across
    turning = np.stack([z[:, 0] * c - z[:, 1] * s, z[:, 0] * s + z[:, 1] * c], axis=1)
    assert travel_frame_test(turning, h).p_value <= 0.001
    assert travel_frame_test(turning, np.full(n, 0.5)).p_value == 1.0


def straight_avenue_trace(seed, n=3600):
    """Walk straight up one avenue; innovations 2.5x larger across it than along."""
    rng = np.random.default_rng(seed)
    b = math.radians(GRID_BEARING_DEG)
    t = np.arange(n, dtype=float)
    north, east = 1.4 * t * math.cos(b), 1.4 * t * math.sin(b)
    z = rng.standard_normal((n + 600, 2)) * 1.5 * math.sqrt(2.0 / (1.0 + 2.5 ** 2))
    along, across = z[:, 0], 2.5 * z[:, 1]
    w = np.stack([along * math.cos(b) - across * math.sin(b),
                  along * math.sin(b) + across * math.cos(b)], axis=1)
    err = np.stack([signal.lfilter([1.0], [1.0, -1.18, 0.06, 0.14], w[:, k])
                    for k in range(2)], axis=1)[600:]
    lat0, lon0 = MANHATTAN_DATUM[0], MANHATTAN_DATUM[1]
    tlat, tlon = offset(lat0, lon0, north, east)
    lat, lon = offset(lat0, lon0, north + err[:, 0], east + err[:, 1])
    return Trace('straight.csv', t, np.asarray(lat), np.asarray(lon), np.asarray(tlat),
                 np.asarray(tlon), {})


def test_one_avenue_cannot_tell_a_walk_that_turns_can():
    from gps_error_ros.sim.synthetic import synthetic_trace
    s = diagnose(straight_avenue_trace(2), sims=20).findings
    assert s.effect_names == ['cross_axis_coupling'], s.effect_names
    assert s.tests['travel_frame'].p_value == 1.0       # one direction: no power
    s = diagnose(synthetic_trace('street_canyon', 2), sims=20).findings
    found = {e.name: e for e in s.effects}
    assert 'street_frame' in found and 'cross_axis_coupling' not in found, list(found)
    ev = found['street_frame'].evidence
    assert ev['test'] == 'travel_frame'
    bic = ev['frame_bic']
    assert bic['street_frame'] < bic['cross_axis_coupling'], bic
    assert any(a.effect == 'cross_axis_coupling' and 'turns with the direction' in
               a.reason for a in s.alternatives_rejected)


def test_the_serial_tests_stay_in_the_axes_the_ar_part_is_fitted_in():
    """
    Turned to the travel frame, an AR fitted per north/east axis shows correlation.

    A 16 s wave and the street's ellipse: the PACF rule picks orders 10 and
    10, and the innovations turned along/across the travel fail the serial
    test with 20 degrees of freedom (30 lags less the order), though north
    and east, where the AR part is fitted, pass it.
    """
    split = split_step(synthetic_trace('periodic+street_canyon', 1000, 3600))
    base = fit_base(split)
    family = run_family(split, base)
    assert family.reject['travel_frame'] and family.reject['periodicity']
    cyc = fit_model(split.train, base.orders, ('periodic',), split.truth,
                    period=family.tests['periodicity'].whole('at_period'))
    _, r, d, _ = cyc.score(split.train, split.truth)
    turned = innovation_tests(to_travel_frame(r, d.heading), d.seg, base.orders)
    assert turned['serial_north'].p_value < 0.01
    for ax in ('north', 'east'):
        assert family.tests[f'serial_{ax}'].statistic == \
            innovation_tests(r, d.seg, base.orders)[f'serial_{ax}'].statistic
        assert family.tests[f'serial_{ax}'].p_value > 0.05

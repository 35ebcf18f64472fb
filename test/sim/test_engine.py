"""The fix engine without ROS: steps from the clock, truth handling, rates."""

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.sim.engine import FixEngine, NS
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.profiles import load_profile

LAT, LON = 40.75, -73.99
MODEL = load_profile('DS1').model()
KEY = streams.agent_key(99)


def engine(**kw):
    return FixEngine(MODEL, [KEY], **kw)


def flat(fixes):
    stamps = [f.stamp_ns for f in fixes for _ in f.agents]
    lat = np.concatenate([f.lat for f in fixes]) if fixes else np.zeros(0)
    lon = np.concatenate([f.lon for f in fixes]) if fixes else np.zeros(0)
    return np.array(stamps), lat, lon


def test_one_fix_per_step_and_errors_are_the_model_sequence():
    eng = engine()
    out = []
    for k in range(10, 60):
        eng.add_truth(0, k * NS, LAT, LON, 5.0)
        out += eng.on_clock(k * NS)
    stamps, lat, lon = flat(out)
    assert list(stamps) == [k * NS for k in range(10, 60)]
    n, e = difference(lat, lon, LAT, LON)
    expected = MODEL.simulate(KEY, 50, start=10)[:, 0]
    np.testing.assert_allclose(n, expected[:, 0], atol=1e-6)
    np.testing.assert_allclose(e, expected[:, 1], atol=1e-6)
    assert all(a == 5.0 for f in out for a in f.alt)


def test_clock_jump_yields_every_step_once():
    eng = engine()
    for k in range(1, 12):
        eng.add_truth(0, k * NS, LAT, LON, 0.0)
    out = eng.on_clock(1 * NS) + eng.on_clock(6 * NS + 300) + eng.on_clock(11 * NS)
    stamps, _, _ = flat(out)
    assert list(stamps) == [k * NS for k in range(1, 12)]
    assert eng.on_clock(11 * NS + 5) == []


def test_step_waits_for_bracketing_truth_and_interpolates():
    eng = engine()
    eng.add_truth(0, int(4.5 * NS), LAT, LON, 0.0)
    assert eng.on_clock(5 * NS) == []          # truth at/after 5 s not yet here
    eng.add_truth(0, int(5.5 * NS), LAT + 1e-4, LON, 10.0)
    out = eng.resolve(5 * NS)
    assert len(out) == 1 and out[0].stamp_ns == 5 * NS
    assert out[0].alt[0] == 5.0                # halfway between 0 and 10


def test_hold_then_silence_when_truth_stops():
    eng = engine(max_pose_age=2.0)
    eng.add_truth(0, 10 * NS, LAT, LON, 0.0)
    out = []
    for k in range(10, 20):
        out += eng.on_clock(k * NS)
    stamps, _, _ = flat(out)
    # 10 interpolated exactly; 11 and 12 held (age <= 2 s); then nothing
    assert list(stamps) == [10 * NS, 11 * NS, 12 * NS]
    assert eng.stats.skipped_no_truth >= 5


def test_no_fix_before_first_truth_and_out_of_order_dropped():
    eng = engine()
    assert eng.on_clock(3 * NS) == []
    assert eng.add_truth(0, 4 * NS, LAT, LON, 0.0)
    assert not eng.add_truth(0, int(3.5 * NS), LAT, LON, 0.0)
    assert not eng.add_truth(0, 4 * NS, LAT, LON, 0.0)
    assert eng.stats.dropped_out_of_order == 2
    out = eng.on_clock(5 * NS)
    assert [f.stamp_ns for f in out] == [4 * NS]   # step 3 had no truth before it


def test_clock_backwards_resets():
    eng = engine()
    for k in range(100, 110):
        eng.add_truth(0, k * NS, LAT, LON, 0.0)
        eng.on_clock(k * NS)
    assert eng.on_clock(50 * NS) == []             # history discarded
    assert eng.stats.resets == 1
    eng.add_truth(0, 50 * NS, LAT, LON, 0.0)
    out = eng.on_clock(50 * NS) + eng.resolve(50 * NS)
    assert [f.stamp_ns for f in out] == [50 * NS]
    n, e = difference(out[0].lat, out[0].lon, LAT, LON)
    # restarted from the stationary law at step 50
    np.testing.assert_allclose([n[0], e[0]],
                               MODEL.simulate(KEY, 1, start=50)[0, 0], atol=1e-6)


def test_rate_above_model_rate_holds_error():
    eng = engine(rate=4.0)
    out = []
    for q in range(40, 80):                    # 10 s at 4 Hz
        ns = q * NS // 4
        eng.add_truth(0, ns, LAT, LON, 0.0)
        out += eng.on_clock(ns)
    stamps, lat, lon = flat(out)
    assert len(stamps) == 40
    n, _ = difference(lat, lon, LAT, LON)
    groups = n.reshape(10, 4)
    assert np.allclose(groups, groups[:, :1], atol=1e-9)   # held within a second
    np.testing.assert_allclose(groups[:, 0],
                               MODEL.simulate(KEY, 10, start=10)[:, 0, 0], atol=1e-6)


def test_rate_below_model_rate_samples_model():
    eng = engine(rate=0.5)
    out = []
    for k in range(100, 140):
        eng.add_truth(0, k * NS, LAT, LON, 0.0)
        out += eng.on_clock(k * NS)
    stamps, lat, lon = flat(out)
    assert list(stamps) == [k * NS for k in range(100, 140, 2)]
    n, _ = difference(lat, lon, LAT, LON)
    np.testing.assert_allclose(n, MODEL.simulate(KEY, 40, start=100)[::2, 0, 0],
                               atol=1e-6)


def test_future_stamped_truth_is_dropped():
    eng = engine(max_pose_age=1.0)
    eng.add_truth(0, 10 * NS, LAT, LON, 0.0)
    eng.on_clock(10 * NS)
    assert not eng.add_truth(0, 100 * NS, LAT + 1e-3, LON, 0.0)   # 90 s ahead
    assert not eng.add_truth(0, 71 * NS, LAT + 1e-3, LON, 0.0)    # 61 s ahead
    assert eng.stats.dropped_future == 2
    assert eng.add_truth(0, 30 * NS, LAT, LON, 0.0)             # 20 s ahead: fine
    kept = eng.add_truth_batch([0, 0], [40 * NS, 500 * NS], [[LAT, LON, 0]] * 2)
    assert list(kept) == [True, False] and eng.stats.dropped_future == 3


def test_no_interpolation_across_a_long_truth_gap():
    eng = engine(max_pose_age=1.0)               # longest bridged gap: 2 s
    out = []
    eng.add_truth(0, 10 * NS, LAT, LON, 0.0)
    out += eng.on_clock(10 * NS)
    for k in range(11, 16):
        out += eng.on_clock(k * NS)
    eng.add_truth(0, 16 * NS, LAT + 1e-3, LON, 0.0)   # 6 s after the previous
    out += eng.on_clock(16 * NS)
    stamps = [f.stamp_ns for f in out]
    # 10 exact, 11 held (1 s), 12-15 nothing (gap), 16 exact
    assert stamps == [10 * NS, 11 * NS, 16 * NS]


def test_batch_add_keeps_order_per_agent():
    eng = FixEngine(MODEL, streams.agent_keys(1, ['a', 'b']))
    kept = eng.add_truth_batch([0, 1, 0, 0, 1], [5, 7, 6, 6, 3],
                               [[LAT, LON, 0.0]] * 5)
    # a: 5 then 6 kept, duplicate 6 dropped; b: 7 kept, then 3 out of order
    assert list(kept) == [True, True, True, False, False]
    assert eng.stats.dropped_out_of_order == 2


def test_truth_behind_the_clock_is_counted_as_late():
    """A clock 3 s ahead of its poses: steps are skipped, and that is noticed."""
    eng = engine(max_pose_age=1.0)
    eng.add_truth(0, 9 * NS, LAT, LON, 0.0)
    fixes = []
    for k in range(10, 30):
        fixes += eng.on_clock(k * NS)
        eng.add_truth(0, (k - 3) * NS, LAT, LON, 0.0)     # truth 3 s behind
    assert eng.stats.skipped_no_truth > 0
    assert eng.stats.late_truth > 0
    ok = engine(max_pose_age=4.0)                          # the advice works
    ok.add_truth(0, 9 * NS, LAT, LON, 0.0)
    for k in range(10, 30):
        ok.on_clock(k * NS)
        ok.add_truth(0, (k - 3) * NS, LAT, LON, 0.0)
    assert ok.stats.skipped_no_truth == 0 and ok.stats.late_truth == 0
    quiet = engine(max_pose_age=1.0)                       # truth that stops is not late
    quiet.add_truth(0, 9 * NS, LAT, LON, 0.0)
    for k in range(10, 30):
        quiet.on_clock(k * NS)
    assert quiet.stats.skipped_no_truth > 0 and quiet.stats.late_truth == 0
    new = engine(max_pose_age=1.0)                         # nor truth that only begins
    for k in range(10, 30):
        new.on_clock(k * NS)
        if k >= 20:
            new.add_truth(0, k * NS, LAT, LON, 0.0)
    assert new.stats.skipped_no_truth == 10 and new.stats.late_truth == 0


def test_a_fixed_start_makes_fixes_independent_of_the_first_clock_reading():
    """start_ns: the streams begin there, whether the first reading is on time or late."""
    def run(first_clock, start_ns=10 * NS):
        eng = engine(max_pose_age=1.0, start_ns=start_ns)
        if start_ns is not None:
            assert eng.on_clock(5 * NS) == []       # before the start: ignored
        out = []
        for k in range(10, 30):
            eng.add_truth(0, k * NS, LAT, LON, 0.0)
            if k >= first_clock:
                out += eng.on_clock(k * NS)
        return {f.stamp_ns: (f.lat[0], f.lon[0]) for f in out if f.agents.size}
    on_time, late = run(10), run(14)
    assert sorted(on_time) == [k * NS for k in range(10, 30)]
    assert on_time == late          # steps 10-13 served from the truth received
    assert run(14, None) != late    # without it, the streams begin at 14


def test_invalid_truth_is_a_gap_not_a_clock_ahead():
    """Five seconds of NaN poses: their steps get nothing, and that is not called lateness."""
    eng = engine(max_pose_age=1.0)
    served = []
    for k in range(0, 20):
        if 5 <= k < 10:
            eng.note_invalid(0, k * NS)                    # what the node drops
        else:
            eng.add_truth(0, k * NS, LAT, LON, 0.0)
        served += [f.stamp_ns // NS for f in eng.on_clock(k * NS)]
    # the last valid pose is held for max_pose_age (step 5); then no fix and no NO_FIX
    assert [k for k in range(6, 10) if k in served] == []
    assert all(k in served for k in list(range(1, 6)) + list(range(10, 20)))   # 0: no clock
    assert eng.stats.late_truth == 0 and eng.stats.invalid_gaps == 1

"""The study's figures from logs made by hand: warnings, lead times, delivery by distance."""

import numpy as np

from gps_error_ros.ns3.crossing import pedestrians, vehicles
from gps_error_ros.ns3.tracks import Tracks
from gps_error_ros.ns3.p2v_metrics import delivery, encounters, Rule, score, warnings, wilson

RULE = Rule()


def scene():
    """One pedestrian crossing the lane at x = 0; one vehicle driving east at 10 m/s."""
    ped = Tracks(['p'], [np.array([0.0, 10.0, 30.0])],
                 [np.array([[0.0, 8.0], [0.0, 8.0], [0.0, -16.0]])])    # crosses from t = 10
    car = Tracks(['v'], [np.array([0.0, 30.0])], [np.array([[-200.0, -1.75], [100.0, -1.75]])])
    return ped, car


def logs_of(ped, shift=(0.0, 0.0), rate=10.0, duration=30.0):
    """Return logs of messages sent at ``rate`` from the true track (+ ``shift``), all received."""
    t = np.arange(0.05, duration, 1.0 / rate)
    fix_t = np.floor(t)
    xy = ped.at(fix_t)[0] + np.asarray(shift)
    v = ped.velocity(fix_t)[0]
    n = t.size
    return {'tx_node': np.zeros(n, dtype=np.int64), 'tx_count': np.arange(n),
            'tx_time': t, 'tx_fix_time': fix_t, 'tx_x': xy[:, 0], 'tx_y': xy[:, 1],
            'tx_speed': np.hypot(v[:, 0], v[:, 1]),
            'tx_heading': np.degrees(np.arctan2(v[:, 0], v[:, 1])) % 360,
            'rx_node': np.zeros(n, dtype=np.int64), 'rx_from': np.zeros(n, dtype=np.int64),
            'rx_count': np.arange(n), 'rx_time': t + 1e-3}


def test_a_true_message_warns_ahead_and_a_displaced_one_does_not():
    """The vehicle reaches x = 0 at t = 20, when the walker is in its lane: one encounter."""
    ped, car = scene()
    ticks = np.arange(0.0, 30.0, RULE.tick)
    found, where, vel = encounters(ped, car, ticks, RULE)
    assert len(found) == 1 and abs(ticks[found[0][2]] - 19.8) < 0.15
    good = score(found, warnings(logs_of(ped), 1, where, vel, ticks, RULE), ticks, RULE)
    assert good['hits'] == 1 and good['false_warnings'] == 0
    assert 3.0 <= good['lead_s'][0] <= RULE.horizon
    off = score(found, warnings(logs_of(ped, (15.0, 0.0)), 1, where, vel, ticks, RULE),
                ticks, RULE)
    assert off['misses'] == 1 and off['hits'] == 0


def test_a_walker_placed_in_the_lane_is_a_false_warning():
    """A walker who stays at the kerb, but whose messages put it in the lane."""
    ped = Tracks(['p'], [np.array([0.0, 30.0])], [np.array([[0.0, 8.0], [0.0, 8.0]])])
    _, car = scene()
    ticks = np.arange(0.0, 30.0, RULE.tick)
    found, where, vel = encounters(ped, car, ticks, RULE)
    assert found == []
    res = score(found, warnings(logs_of(ped, (0.0, -9.75)), 1, where, vel, ticks, RULE),
                ticks, RULE)
    assert res['warnings'] == res['false_warnings'] == 1


def test_stale_messages_warn_of_nothing():
    """Messages older than max_age are not used: received only in the first 5 s, no warning."""
    ped, car = scene()
    ticks = np.arange(0.0, 30.0, RULE.tick)
    found, where, vel = encounters(ped, car, ticks, RULE)
    logs = logs_of(ped)
    early = logs['rx_time'] < 5.0
    for k in ('rx_node', 'rx_from', 'rx_count', 'rx_time'):
        logs[k] = logs[k][early]
    res = score(found, warnings(logs, 1, where, vel, ticks, RULE), ticks, RULE)
    assert res['misses'] == 1 and res['warnings'] == 0


def test_delivery_counts_each_message_once_per_vehicle_at_its_distance():
    """Sent counts every message for the vehicle; delivered only the received ones."""
    ped, car = scene()
    logs = logs_of(ped)
    keep = logs['rx_count'] % 2 == 0
    for k in ('rx_node', 'rx_from', 'rx_count', 'rx_time'):
        logs[k] = logs[k][keep]
    edges = np.arange(0.0, 450.0, 50.0)
    sent, got, error = delivery(logs, ped, car, edges)
    assert sent.sum() == logs['tx_time'].size
    assert got.sum() == keep.sum()
    assert error.max() <= 1.2 + 1e-9      # a fix up to a second old, the walker at 1.2 m/s


def test_wilson_interval():
    """Known values: 0 of 10 and 5 of 10."""
    lo, hi = wilson(0, 10)
    assert lo == 0.0 or abs(lo) < 1e-12
    assert abs(hi - 0.2775) < 1e-3
    lo, hi = wilson(5, 10)
    assert abs(lo - 0.2366) < 1e-3 and abs(hi - 0.7634) < 1e-3


def test_the_scenario_keeps_its_walkers_on_the_sidewalks_and_crosswalks():
    """Every walker's points lie on a sidewalk line or a corner; vehicles keep their lane."""
    rng = np.random.default_rng(3)
    peds, cars = pedestrians(50, 60.0, rng), vehicles(8, 60.0, rng)
    for pts in peds.points:
        assert np.all(np.isclose(np.abs(pts), 8.0).any(axis=1))
    for pts in cars.points:
        assert np.all(np.isclose(np.abs(pts), 1.75).any(axis=1))
    v = cars.velocity(np.array([30.0]))
    assert np.all(np.hypot(v[:, 0, 0], v[:, 0, 1]) <= 14.0 + 1e-9)

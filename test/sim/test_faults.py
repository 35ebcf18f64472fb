"""Faults on demand: the schedule, each kind's effect on the fixes, and the stream after."""

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.sim.faults import (Fault, FaultError, faults_from_yaml, GROSS_SIZE_M,
                                      load_schedule, NS, schedule_text)
from gps_error_ros.sim.simulate import simulate_csv

LAT0, LON0 = 40.75057, -73.99065
T0, STEPS = 1000, 60
SEED = 7
#: A fitted phone profile with a velocity section.
PHONE = Path(__file__).parents[2] / 'docs/calibration/gsdc2020-mtv1-pixel4-ar3.yaml'


def _trajectory(path, agents=('ann', 'bob')):
    """Write a CSV of agents walking east at 1.3 m/s from LAT0, LON0, a row per second."""
    with open(path, 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(['t', 'agent', 'truth_lat', 'truth_lon'])
        for k in range(STEPS):
            lon = LON0 + 1.3 * k / (111_320 * math.cos(math.radians(LAT0)))
            for i, a in enumerate(agents):
                w.writerow([T0 + k, a, f'{LAT0 + 1e-4 * i:.9f}', f'{lon:.9f}'])
    return path


def _run(tmp_path, faults, name, profile='DS5', mode='stationary', velocity=False):
    prof = load_profile(profile)
    out = tmp_path / f'{name}.csv'
    simulate_csv(_trajectory(tmp_path / 'truth.csv'), out, prof.model(about_truth=True),
                 prof.rate_hz, SEED, velocity=prof.velocity if velocity else None,
                 covariance_mode=mode, faults=faults)
    with open(out, newline='') as f:
        rows = list(csv.DictReader(f))
    by = {}
    for r in rows:
        by.setdefault(r['agent'], []).append(r)
    return by


def _num(r, k):
    return float(r[k]) if r.get(k) not in (None, '') else math.nan


def _fixed(r):
    return r.get('status', 'fix') != 'no_fix' and r['lat'] != ''


def _error(r):
    n, e = difference(_num(r, 'lat'), _num(r, 'lon'), _num(r, 'truth_lat'),
                      _num(r, 'truth_lon'))
    return np.array([float(n), float(e)])


def _plain(rows):
    """Return ``rows`` without the status column (a run with faults writes one)."""
    return [{k: v for k, v in r.items() if k != 'status'} for r in rows]


def _in(r, at, duration):
    return at <= float(r['t']) < at + duration


def test_each_kind_does_what_it_says_and_the_stream_goes_on(tmp_path):
    base = _run(tmp_path, [], 'base')
    schedule = faults_from_yaml('''
faults:
  - {kind: outage, at: 1005, duration: 4, agent: ann}
  - {kind: frozen, at: 1015, duration: 6, agent: ann, growth_mps: 2.0}
  - {kind: offset, at: 1025, duration: 5, agent: ann, size_m: 25, bearing_deg: 90}
  - {kind: degraded, at: 1035, duration: 5, agent: ann, scale: 3}
  - {kind: gross_failure, at: 1045, agent: ann, size_m: 3000, bearing_deg: 180}
''')
    got = _run(tmp_path, schedule, 'faulted')
    ann0, ann = base['ann'], got['ann']
    assert _plain(got['bob']) == _plain(base['bob']), 'a fault on ann touched bob'
    frozen_first = next(r for r in ann if _in(r, 1015, 6))
    for r0, r in zip(ann0, ann):
        t = float(r['t'])
        if _in(r, 1005, 4):
            assert not _fixed(r) and r['status'] == 'no_fix'
        elif _in(r, 1015, 6):
            assert (r['lat'], r['lon']) == (frozen_first['lat'], frozen_first['lon'])
            # the stated SD grows from the first fix's by 2 m/s of age
            age = t - 1015
            want = math.hypot(_num(frozen_first, 'accuracy_major'), 2.0 * age)
            assert _num(r, 'accuracy_major') == pytest.approx(want, rel=1e-3, abs=1e-3)
        elif _in(r, 1025, 5):
            np.testing.assert_allclose(_error(r) - _error(r0), [0.0, 25.0], atol=1e-6)
            assert r['accuracy'] == r0['accuracy']          # the receiver does not know
        elif _in(r, 1035, 5):
            np.testing.assert_allclose(_error(r), 3 * _error(r0), atol=1e-6)
            assert _num(r, 'accuracy_major') == pytest.approx(3 * _num(r0, 'accuracy_major'),
                                                              abs=2e-3)
        elif t == 1045:
            np.testing.assert_allclose(_error(r) - _error(r0), [-3000.0, 0.0], atol=1e-6)
        else:       # outside every fault: the run as it was without them
            assert (r['lat'], r['lon'], r['accuracy']) == (r0['lat'], r0['lon'], r0['accuracy'])
    assert frozen_first['lat'] == next(r for r in ann0 if _in(r, 1015, 6))['lat']


def test_a_fault_for_every_agent_and_overlaps_in_order(tmp_path):
    base = _run(tmp_path, [], 'base')
    got = _run(tmp_path, faults_from_yaml('''
- {kind: offset, at: 1010, duration: 10, size_m: 10}
- {kind: outage, at: 1015, duration: 2, agent: '*'}
'''), 'faulted')
    for name in ('ann', 'bob'):
        for r0, r in zip(base[name], got[name]):
            if _in(r, 1015, 2):
                assert not _fixed(r)                       # an outage wins
            elif _in(r, 1010, 10):
                np.testing.assert_allclose(_error(r) - _error(r0), [10.0, 0.0], atol=1e-6)
            else:
                assert _plain([r]) == _plain([r0])


def test_a_frozen_receiver_repeats_its_velocity(tmp_path):
    base = _run(tmp_path, [], 'base', profile=PHONE, velocity=True)
    got = _run(tmp_path, [Fault('frozen', 1020 * NS, 5 * NS, 'bob')], 'frozen',
               profile=PHONE, velocity=True)
    window = [r for r in got['bob'] if _in(r, 1020, 5)]
    assert len(window) == 5
    assert {(r['speed'], r['bearing']) for r in window} == {(window[0]['speed'],
                                                             window[0]['bearing'])}
    assert window[0]['speed'] == next(r for r in base['bob'] if _in(r, 1020, 5))['speed']


def test_a_gross_failure_is_one_fix_per_agent(tmp_path):
    base = _run(tmp_path, [], 'base')
    got = _run(tmp_path, faults_from_yaml(
        '{kind: gross_failure, at: 1030.5, duration: 5}'), 'gross')
    for name in ('ann', 'bob'):
        far = [float(r['t']) for r0, r in zip(base[name], got[name])
               if np.linalg.norm(_error(r) - _error(r0)) > 1.0]
        assert far == [1031.0], name
        r = next(r for r in got[name] if float(r['t']) == 1031.0)
        r0 = next(r for r in base[name] if float(r['t']) == 1031.0)
        assert np.linalg.norm(_error(r) - _error(r0)) == pytest.approx(GROSS_SIZE_M, abs=1e-6)


@pytest.mark.parametrize('text, says', [
    ('{kind: jam, at: 1, duration: 2}', 'kind must be one of'),
    ('{kind: outage, at: 1}', 'outage needs duration'),
    ('{kind: offset, at: 1, duration: 2}', 'offset needs size_m'),
    ('{kind: outage, at: 1, duration: 2, scale: 3}', 'unknown: scale'),
    ('{kind: degraded, at: 1, duration: 2, scale: 0}', 'scale must be > 0'),
    ('{kind: outage, at: -1, duration: 2}', 'at must be >= 0'),
    ('{kind: outage, at: 1, duration: .nan}', 'duration must be a finite number'),
    ('{kind: outage, at: 1, duration: 2, agent: 3}', 'agent must be'),
    ('[1, 2]', 'fault 1: expected a mapping'),
    ('faults: 3', 'expected a list of faults'),
    ('faults: []\nextra: 1', "only a 'faults' list"),
    ('{kind: [', 'not YAML'),
])
def test_a_bad_entry_is_named(text, says):
    with pytest.raises(FaultError, match='schedule') as info:
        faults_from_yaml(text, 'schedule')
    assert says in str(info.value)


def test_a_schedule_file_round_trips(tmp_path):
    faults = [Fault('outage', 5 * NS, 2 * NS, 'ann'),
              Fault('degraded', 9 * NS, NS, None, scale=2.5)]
    path = tmp_path / 'faults.yaml'
    path.write_text(schedule_text(faults))
    assert load_schedule(path) == faults
    with pytest.raises(FaultError, match='cannot read it'):
        load_schedule(tmp_path / 'missing.yaml')


def test_at_may_be_left_to_the_caller_at_run_time():
    (fault,) = faults_from_yaml('{kind: outage, duration: 3}', 'faults', now_s=12.5)
    assert (fault.at_ns, fault.end_ns, fault.agent) == (12_500_000_000, 15_500_000_000, None)
    with pytest.raises(FaultError, match='outage needs at'):
        faults_from_yaml('{kind: outage, duration: 3}', 'faults')

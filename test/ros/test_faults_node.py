"""
Faults on demand in the error node: from a schedule file and set at run time.

Each fault kind is put on a chosen agent at a chosen step through a real node
process; the fixes must equal what ``simulate`` gives for the same
trajectory, seed and schedule (to 1e-6 m, as every effect), and the
published status and covariance must be the fault's.
"""

import csv

from geometry_msgs.msg import PoseStamped
import numpy as np
import pytest
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.model.geodesy import difference, LocalTangentFrame
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.sim.faults import faults_from_yaml, load_schedule
from gps_error_ros.sim.simulate import simulate_csv
from ros_harness import (covariances_ne, DATUM, DATUM_ARG, drive, drive_agents, NS,
                         stamp_ns, start, T0, unique_ns)

pytestmark = pytest.mark.integration
STEPS = 40
SEED = 21
FRAME = LocalTangentFrame(*DATUM)
SCHEDULE = f'''
faults:
  - {{kind: outage, at: {T0 + 4}, duration: 3}}
  - {{kind: frozen, at: {T0 + 10}, duration: 5, growth_mps: 2.0}}
  - {{kind: offset, at: {T0 + 18}, duration: 4, size_m: 30, bearing_deg: 45}}
  - {{kind: degraded, at: {T0 + 25}, duration: 4, scale: 4}}
  - {{kind: gross_failure, at: {T0 + 32}, size_m: 2500, bearing_deg: 270}}
'''


def _walk(k):
    """Return the (east, north) metres of the walker at simulated second ``k``."""
    return 1.3 * (k - T0), 0.4 * (k - T0)


def _expected(tmp_path, agents, faults, walk=_walk):
    """Return {agent: {stamp_ns: row}} of ``simulate`` on the trajectory the node is driven."""
    truth = tmp_path / 'truth.csv'
    with open(truth, 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(['t', 'agent', 'truth_lat', 'truth_lon'])
        for k in range(T0, T0 + STEPS):
            e, n = walk(k)
            lat, lon, _ = FRAME.to_geodetic(e, n, 0.0)
            for a in agents:
                w.writerow([k, a, repr(float(lat)), repr(float(lon))])
    prof = load_profile('DS5')
    out = tmp_path / 'expected.csv'
    simulate_csv(truth, out, prof.model(about_truth=True), prof.rate_hz, SEED, faults=faults)
    rows: dict[str, dict[int, dict[str, str]]] = {}
    with open(out, newline='') as f:
        for r in csv.DictReader(f):
            rows.setdefault(r['agent'], {})[int(round(float(r['t']))) * NS] = r
    return rows


def _check_same(fixes, expected):
    """Assert the node's fixes are simulate's rows: status, position to 1e-6 m, accuracy."""
    from gps_error_ros.model.accuracy import ellipse
    assert sorted(stamp_ns(f.header.stamp) for f in fixes) == sorted(expected)
    for f in fixes:
        r = expected[stamp_ns(f.header.stamp)]
        if r['status'] == 'no_fix':
            assert f.status.status == NavSatStatus.STATUS_NO_FIX, r['t']
            continue
        assert f.status.status == NavSatStatus.STATUS_FIX, r['t']
        north, east = difference(f.latitude, f.longitude, float(r['lat']), float(r['lon']))
        assert np.hypot(north, east) < 1e-6, (r['t'], float(north), float(east))
        major, _, _ = ellipse(covariances_ne([f]))
        assert major[0] == pytest.approx(float(r['accuracy_major']), rel=1e-9), r['t']


def test_a_schedule_file_puts_every_kind_on_the_walker(tmp_path, peer):
    path = tmp_path / 'faults.yaml'
    path.write_text(SCHEDULE)
    ns = unique_ns()
    node = start(ns, 'profile:=DS5', DATUM_ARG, f'seed:={SEED}', f'fault_schedule:={path}')
    pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pub, f'{ns}/fix', node)
    drive(peer, pub, fixes, STEPS, position=_walk)
    rc, out = node.stop()
    assert rc == 0, out
    assert 'fault schedule' in out and '5 fault(s)' in out
    expected = _expected(tmp_path, [''], load_schedule(path))['']
    _check_same(fixes, expected)
    by = {stamp_ns(f.header.stamp) // NS - T0: f for f in fixes}
    assert all(by[k].status.status == NavSatStatus.STATUS_NO_FIX for k in (4, 5, 6))
    # frozen: the position of step 10 repeated, its covariance growing by 2 m/s of age
    covs = {k: covariances_ne([by[k]])[0] for k in range(10, 15)}
    for k in range(11, 15):
        assert (by[k].latitude, by[k].longitude) == (by[10].latitude, by[10].longitude)
        np.testing.assert_allclose(covs[k], covs[10] + (2.0 * (k - 10)) ** 2 * np.eye(2),
                                   rtol=1e-9)
    assert (by[15].latitude, by[15].longitude) != (by[10].latitude, by[10].longitude)


def _set_faults(peer, ns, text):
    """Set the node's ``faults`` parameter through its SetParameters service; return the result."""
    client = peer.node.create_client(SetParameters, f'{ns}/gps_error_node/set_parameters')
    assert client.wait_for_service(timeout_sec=10.0)
    value = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=text)
    future = client.call_async(SetParameters.Request(
        parameters=[Parameter(name='faults', value=value)]))
    assert peer.spin_until(future.done, 10.0)
    peer.node.destroy_client(client)
    return future.result().results[0]


def test_faults_set_at_run_time_land_on_the_chosen_agent(tmp_path, peer):
    names = ['ann', 'bob']
    ns = unique_ns()
    node = start(ns, 'profile:=DS5', DATUM_ARG, f'seed:={SEED}', 'agents:=["ann", "bob"]')
    pubs = {n: peer.publisher(PoseStamped, f'{ns}/{n}/pose') for n in names}
    fixes = {n: peer.collect(NavSatFix, f'{ns}/{n}/fix') for n in names}
    for n in names:
        peer.wait_connected(pubs[n], f'{ns}/{n}/fix', node)

    def ready(k):
        return all(fixes[n] and stamp_ns(fixes[n][-1].header.stamp) >= k * NS for n in names)

    assert drive_agents(peer, pubs, 3, ready) == []
    bad = _set_faults(peer, ns, '{kind: jam, at: 1, duration: 2}')
    assert not bad.successful and 'kind must be one of' in bad.reason
    stranger = _set_faults(peer, ns, f'{{kind: outage, agent: carol, at: {T0 + 30}, '
                                     f'duration: 2}}')
    assert not stranger.successful and "['carol'] not served by this node" in stranger.reason
    assert 'its agents: ann, bob' in stranger.reason
    over = _set_faults(peer, ns, f'{{kind: outage, at: {T0 - 10}, duration: 2}}')
    assert not over.successful and "ends before the node's clock" in over.reason
    # every kind on ann, from step 4 on (set at step 2: the node has not reached them)
    schedule = SCHEDULE.replace('{kind', '{agent: ann, kind')
    ok = _set_faults(peer, ns, schedule.split('faults:', 1)[1])
    assert ok.successful, ok.reason
    assert drive_agents(peer, pubs, STEPS - 3, ready, start_s=T0 + 3) == []
    rc, out = node.stop()
    assert rc == 0, out
    assert 'faults added: outage on ann' in out
    expected = _expected(tmp_path, names, faults_from_yaml(schedule), walk=lambda k: (0.0, 0.0))
    for n in names:
        _check_same(fixes[n], expected[n])
    assert sum(f.status.status == NavSatStatus.STATUS_NO_FIX for f in fixes['ann']) == 3
    assert all(f.status.status == NavSatStatus.STATUS_FIX for f in fixes['bob'])


def test_a_fault_set_without_at_covers_its_whole_duration_from_the_next_step(peer):
    # the step at the clock's reading has gone out when the fault is set: an
    # outage of 3 s without at is the next 3 steps, not 2 of them
    ns = unique_ns()
    node = start(ns, 'profile:=DS5', DATUM_ARG, f'seed:={SEED}')
    pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pub, f'{ns}/fix', node)
    drive(peer, pub, fixes, 5)                       # steps T0 .. T0 + 4 out
    ok = _set_faults(peer, ns, '{kind: outage, duration: 3}')
    assert ok.successful, ok.reason
    drive(peer, pub, fixes, 10, start_s=T0 + 5)
    rc, out = node.stop()
    assert rc == 0, out
    assert f'from {T0 + 5:.3f} s for 3 s' in out, out
    # the start-up line says what the profile carries: here no gross failures
    assert 'profile DS5: ' in out and '(name DS5; no gross failures)' in out, out
    no_fix = [stamp_ns(f.header.stamp) // NS for f in fixes
              if f.status.status == NavSatStatus.STATUS_NO_FIX]
    assert no_fix == [T0 + 5, T0 + 6, T0 + 7]

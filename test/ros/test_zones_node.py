"""
Zone maps in the node: a crowd walks from one zone into another.

A real node process with a real GeoJSON file: its fixes equal ``gps_error
simulate --zones`` on the same truth to 1e-6 m, gross failures of the default
profile included, and each fix's covariance is the stationary covariance of
the zone its truth is in.
"""

import csv
import json

import numpy as np
import pytest
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.profiles import load_profile
from ros_harness import NodeProcess, NS, Peer, stamp, stamp_ns, T0, unique_ns

pytestmark = pytest.mark.integration
LAT0, LON0 = 40.75057, -73.99065
DEG_PER_M = 1.0 / (111320.0 * np.cos(np.radians(LAT0)))
SPEED = 10.0            # m/s east: the walkers cross into the east zone at ~20 s
BORDER = LON0 + 205.0 * DEG_PER_M
STEPS = 40
AGENTS = ['ann', 'bob']


def zone_map(path):
    """Write DS1 west of BORDER, DS5 east of it; return the path."""
    def box(lon0, lon1):
        ring = [[lon0, LAT0 - 0.01], [lon1, LAT0 - 0.01], [lon1, LAT0 + 0.01],
                [lon0, LAT0 + 0.01], [lon0, LAT0 - 0.01]]
        return {'type': 'Polygon', 'coordinates': [ring]}
    path.write_text(json.dumps({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'name': 'west', 'profile': 'DS1'},
         'geometry': box(LON0 - 0.01, BORDER)},
        {'type': 'Feature', 'properties': {'name': 'east', 'profile': 'DS5'},
         'geometry': box(BORDER, LON0 + 0.02)}]}))
    return path


def truth(k, agent):
    """Return where ``agent`` truly is at simulated second ``k``: (lat, lon)."""
    north = 0.0 if agent == 'ann' else 30.0
    return LAT0 + north / 111320.0, float(LON0 + SPEED * (k - T0) * DEG_PER_M)


def truth_msg(k, agent):
    m = NavSatFix()
    m.header.stamp = stamp(k * NS)
    m.header.frame_id = 'gps'
    m.status.status = 0
    m.latitude, m.longitude = truth(k, agent)
    m.altitude = 10.0
    return m


# without and with a population: each agent's bias (SD 2 m north, 3 m east,
# wandering) and scale, the same in every zone
@pytest.mark.parametrize('bias_sd', [None, (2.0, 3.0)])
def test_fixes_follow_the_zone_and_match_simulate(tmp_path, bias_sd):
    from gps_error_ros.cli import main as gps_error
    from gps_error_ros.model.profiles import builtin_dir
    zones = zone_map(tmp_path / 'zones.geojson')
    # the default profile (DS2) with gross failures: they serve every zone
    default = tmp_path / 'ds2-failing.yaml'
    default.write_text((builtin_dir() / 'DS2.yaml').read_text()
                       + 'gross_failures: {rate: 0.1, sizes_m: [60, 200]}\n'
                       + ('' if bias_sd is None else
                          f'population: {{bias_sd_m: {list(bias_sd)}, scale_sd_log: 0.3, '
                          f'bias_time_constant_s: 30}}\n'))
    ns = unique_ns()
    node = NodeProcess(['--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true',
                        '-p', 'input_type:=navsatfix', '-p', 'seed:=9',
                        '-p', f'profile:={default}',
                        '-p', f'zones:={zones}', '-p', 'agents:=["ann","bob"]'])
    peer = Peer()
    try:
        pubs = {a: peer.publisher(NavSatFix, f'{ns}/{a}/fix_truth') for a in AGENTS}
        boxes = {a: peer.collect(NavSatFix, f'{ns}/{a}/fix') for a in AGENTS}
        assert peer.spin_until(lambda: all(p.get_subscription_count() for p in pubs.values())
                               and all(peer.node.count_publishers(f'{ns}/{a}/fix')
                                       for a in AGENTS), 20)
        peer.spin_for(0.5)
        for k in range(T0, T0 + STEPS + 1):
            for a in AGENTS:
                pubs[a].publish(truth_msg(k, a))
            peer.set_clock(k * NS)
            peer.spin_until(lambda: all(b and stamp_ns(b[-1].header.stamp) >= (k - 1) * NS
                                        for b in boxes.values()), 5)
        rc, out = node.stop()
        assert rc == 0, out
        # what serves outside the zones, and each zone's profile, by name
        assert f'profile {default} outside the zones' in out, out
        assert 'west profile DS1, east profile DS5' in out, out
    finally:
        node.stop()
        peer.destroy()
    src, dst = tmp_path / 'truth.csv', tmp_path / 'noisy.csv'
    with open(src, 'w') as f:
        f.write('t,agent,truth_lat,truth_lon\n')
        for k in range(T0, T0 + STEPS):
            for a in AGENTS:
                f.write('{},{},{!r},{!r}\n'.format(k, a, *truth(k, a)))
    assert gps_error(['simulate', '--profile', str(default), '--seed', '9',
                      '--zones', str(zones), '--trajectories', str(src), '--out', str(dst)]) == 0
    sim = {(r['agent'], int(float(r['t']))): r for r in csv.DictReader(open(dst))}
    # about the truth (the default): the zone's mean square error matrix
    var = {name: np.diag(load_profile(name).model(about_truth=True).stationary_cov)
           + (0.0 if bias_sd is None else np.square(bias_sd)) for name in ('DS1', 'DS5')}
    seen = {'DS1': 0, 'DS5': 0, 'failed': 0}
    for a in AGENTS:
        for m in boxes[a]:
            k = stamp_ns(m.header.stamp) // NS
            if (a, k) not in sim:
                continue
            lat, lon = truth(k, a)
            node_err = difference(m.latitude, m.longitude, lat, lon)
            row = sim[a, k]
            sim_err = difference(float(row['lat']), float(row['lon']), lat, lon)
            np.testing.assert_allclose(np.ravel(node_err), np.ravel(sim_err), rtol=0,
                                       atol=1e-6, err_msg=f'{a} {k}')
            seen['failed'] += int(np.hypot(*np.ravel(node_err)) > 59.0)
            zone = 'DS1' if lon < BORDER else 'DS5'
            c = m.position_covariance
            assert (c[4], c[0]) == pytest.approx(tuple(var[zone]), rel=1e-9), (a, k, zone)
            seen[zone] += 1
    # 80 fixes at a rate of 0.1: 8 failures expected, at least 1 with probability 0.9998
    assert seen['DS1'] >= 30 and seen['DS5'] >= 30 and seen['failed'] >= 1, seen


def l_walk(k, agent):
    """Return (lat, lon) of an L-shaped walk: 20 s east at 1.4 m/s, then north."""
    s = k - T0
    north0 = 0.0 if agent == 'ann' else 30.0
    east = 1.4 * min(s, 20)
    north = north0 + 1.4 * max(0, s - 20)
    return LAT0 + north / 111320.0, float(LON0 + east * DEG_PER_M)


def test_street_frame_turns_with_the_walker_in_node_and_simulate(tmp_path):
    """
    A street-frame profile on an L-shaped walk, covariance_mode conditional.

    Node and ``simulate`` agree to 1e-6 m; each fix's covariance is the
    along/across ellipse of the leg the walker is on (east: the small
    variance east; north: the small variance north).
    """
    import yaml
    from gps_error_ros.cli import main as gps_error
    from gps_error_ros.model.profiles import builtin_dir
    raw = yaml.safe_load((builtin_dir() / 'DS1.yaml').read_text())
    raw['effects'] = {'street_frame': {'sigma_along': 0.5, 'sigma_across': 2.0}}
    prof = tmp_path / 'street.yaml'
    prof.write_text(yaml.safe_dump(raw))
    ns = unique_ns()
    node = NodeProcess(['--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true',
                        '-p', 'input_type:=navsatfix', '-p', 'seed:=3', '-p', f'profile:={prof}',
                        '-p', 'covariance_mode:=conditional', '-p', 'agents:=["ann","bob"]',
                        # the innovation covariance alone, which turns with the walker
                        '-p', 'covariance_about:=mean'])
    peer = Peer()
    try:
        pubs = {a: peer.publisher(NavSatFix, f'{ns}/{a}/fix_truth') for a in AGENTS}
        boxes = {a: peer.collect(NavSatFix, f'{ns}/{a}/fix') for a in AGENTS}
        assert peer.spin_until(lambda: all(p.get_subscription_count() for p in pubs.values())
                               and all(peer.node.count_publishers(f'{ns}/{a}/fix')
                                       for a in AGENTS), 20)
        peer.spin_for(0.5)
        for k in range(T0, T0 + STEPS + 1):
            for a in AGENTS:
                m = truth_msg(k, a)
                m.latitude, m.longitude = l_walk(k, a)
                pubs[a].publish(m)
            peer.set_clock(k * NS)
            peer.spin_until(lambda: all(b and stamp_ns(b[-1].header.stamp) >= (k - 1) * NS
                                        for b in boxes.values()), 5)
        rc, out = node.stop()
        assert rc == 0, out
    finally:
        node.stop()
        peer.destroy()
    src, dst = tmp_path / 'truth.csv', tmp_path / 'noisy.csv'
    with open(src, 'w') as f:
        f.write('t,agent,truth_lat,truth_lon\n')
        for k in range(T0, T0 + STEPS):
            for a in AGENTS:
                f.write('{},{},{!r},{!r}\n'.format(k, a, *l_walk(k, a)))
    assert gps_error(['simulate', '--profile', str(prof), '--seed', '3', '--covariance-mode',
                      'conditional', '--covariance-about', 'mean', '--trajectories', str(src),
                      '--out', str(dst)]) == 0
    sim = {(r['agent'], int(float(r['t']))): r for r in csv.DictReader(open(dst))}
    legs = {'east': 0, 'north': 0}
    for a in AGENTS:
        for m in boxes[a]:
            k = stamp_ns(m.header.stamp) // NS
            if (a, k) not in sim:
                continue
            lat, lon = l_walk(k, a)
            row = sim[a, k]
            np.testing.assert_allclose(
                np.ravel(difference(m.latitude, m.longitude, lat, lon)),
                np.ravel(difference(float(row['lat']), float(row['lon']), lat, lon)),
                rtol=0, atol=1e-6, err_msg=f'{a} {k}')
            c = m.position_covariance
            if 2 <= k - T0 <= 20:           # walking east (a second of history)
                assert (c[0], c[4]) == pytest.approx((0.25, 4.0), rel=1e-9), (a, k, c)
                legs['east'] += 1
            elif k - T0 >= 22:              # walking north
                assert (c[0], c[4]) == pytest.approx((4.0, 0.25), rel=1e-9), (a, k, c)
                legs['north'] += 1
            assert m.position_covariance_type == NavSatFix.COVARIANCE_TYPE_KNOWN
    assert legs['east'] >= 30 and legs['north'] >= 30, legs


def test_the_start_line_names_what_serves_outside_the_zones(tmp_path):
    """A map whose default_profile (DS1) is not the run's profile (DS5): DS1's name and figures."""
    raw = json.loads(zone_map(tmp_path / 'z.geojson').read_text())
    raw['default_profile'] = 'DS1'
    (tmp_path / 'z.geojson').write_text(json.dumps(raw))
    node = NodeProcess(['--ros-args', '-r', f'__ns:={unique_ns()}', '-p', 'profile:=DS5',
                        '-p', 'input_type:=navsatfix', '-p', f'zones:={tmp_path / "z.geojson"}'])
    assert node.wait_output('outside the zones'), node.stop()[1]     # its start-up line
    rc, out = node.stop()
    assert rc == 0, out
    rms = load_profile('DS1').model(about_truth=True).stationary_sd
    assert (f"profile DS1 (the map's default_profile) outside the zones: rms error about "
            f"the truth north {rms[0]:.2f} m, east {rms[1]:.2f} m") in out, out
    assert 'west profile DS1, east profile DS5' in out and 'profile DS5:' not in out, out

"""
gps_error_sumo with a real SUMO: people walk, the error node serves them live.

The scenario is built here with SUMO's own tools (netgenerate grid with
sidewalks and crossings, randomTrips.py --pedestrians). gps_error_sumo runs
it and writes SUMO's FCD output of the same run; the error node serves the
people through agent_pattern as they appear. Every person-step of the FCD
must get exactly one fix, and each fix's error must be what
``gps_error simulate`` adds to that FCD row (same seed and profile).
"""

import subprocess
import xml.etree.ElementTree as ET

from diagnostic_msgs.msg import DiagnosticArray
import numpy as np
import pytest
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.geodesy import difference
from gps_error_ros.ros.sumo_bridge import Georeference, ros_name
from gps_error_ros.sim.sumo_scenario import build_grid_scenario
from ros_harness import node_executable, node_statuses, NodeProcess, NS, status_values, \
    stamp_ns, unique_ns

pytestmark = pytest.mark.integration
SEED = 5


def start_bridge(scenario, fcd, *params):
    """Start gps_error_sumo on ``scenario``, writing SUMO's geo FCD (12 digits) to ``fcd``."""
    args = ['--ros-args', '-p', f'sumocfg:={scenario.sumocfg}',
            '-p', f'sumo_args:=["--fcd-output", "{fcd}", "--fcd-output.geo", "true", '
                  f'"--precision.geo", "12"]']
    for p in params:
        args += ['-p', p]
    return NodeProcess(args, name='gps_error_sumo')


def read_fcd(path):
    """Return {(person id, t): (lat, lon)} of an FCD file written with --fcd-output.geo."""
    out = {}
    for ts in ET.parse(path).getroot().iter('timestep'):
        t = round(float(ts.get('time')))
        for p in ts.iter('person'):
            out[(p.get('id'), t)] = (float(p.get('y')), float(p.get('x')))
    return out


def test_sumo_people_get_the_errors_simulate_gives_their_fcd(tmp_path, peer):
    scenario = build_grid_scenario(tmp_path / 'scenario', grid=3, length=60.0,
                                   depart_until=24.0, period=2.0, seed=7)
    lat0, lon0, _ = Georeference(scenario.net, None).datum
    ns = unique_ns()
    node = NodeProcess([
        '--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true',
        '-p', f'datum:=[{lat0!r}, {lon0!r}, 0.0]', '-p', f'seed:={SEED}',
        # reliable: the bridge waits for a leaving person's last poses to be
        # acknowledged (best effort sends no acknowledgements, and on a loaded
        # machine a person's last one or two steps got no fix)
        '-p', 'profile:=DS5', '-p', 'max_pose_age:=0.5', '-p', 'input_reliability:=reliable',
        '-p', f'start_time:={scenario.begin!r}',
        '-p', f'agent_pattern:={ns}/peds/*/pose', '-p', 'agent_timeout:=3.0'])
    fixes = {p: peer.collect(NavSatFix, f'{ns}/peds/{ros_name(p)}/fix')
             for p in scenario.persons}
    diag = peer.collect(DiagnosticArray, '/diagnostics')
    # the node is up and has seen this peer's subscriptions before SUMO starts
    assert peer.spin_until(lambda: node_statuses(diag, f'{ns}/gps_error_node'), 20), \
        node.stop()[1]
    peer.spin_for(1.0)
    fcd = tmp_path / 'fcd.xml'
    bridge = start_bridge(scenario, fcd, f'person_prefix:={ns}/peds', 'speed:=10.0',
                          'wait_for_clock:=1', 'match_timeout:=10.0')
    try:
        assert peer.spin_until(lambda: bridge.proc.poll() is not None, 300), 'SUMO ran on'
        rc, bridge_log = bridge.wait_exit()
        assert rc == 0, bridge_log
        assert 'SUMO ended' in bridge_log, bridge_log
        # the last steps' fixes may still be on their way on a loaded machine
        steps = len(read_fcd(fcd))
        peer.spin_until(lambda: sum(len(b) for b in fixes.values()) >= steps, 20.0)
        peer.spin_for(1.0)
        statuses = node_statuses(diag, f'{ns}/gps_error_node')
        rc, log = node.stop()
        assert rc == 0, log
        # the streams begin at SUMO's begin time, however late the node read the clock
        assert f'the error streams begin at ROS time {scenario.begin:.3f} s\n' in log, log
    finally:
        node.stop()
        bridge.stop()

    truth = read_fcd(fcd)
    people = {p for p, _ in truth}
    assert len(people) >= 10, people            # people came ...
    # ... and left: released by the node once their topics were gone
    assert int(status_values(statuses[-1])['agents released']) >= len(people) - 3, \
        status_values(statuses[-1])

    # every person-step of SUMO's own output got exactly one fix, and no other step
    got = {}
    for p, box in fixes.items():
        for f in box:
            key = (p, stamp_ns(f.header.stamp) // NS)
            assert key not in got, f'two fixes for {key}'
            assert stamp_ns(f.header.stamp) % NS == 0
            got[key] = (f.latitude, f.longitude)
    missing = sorted(set(truth) - set(got))
    first = {}
    for p, k in sorted(truth):
        first.setdefault(p, k)
    # each missing person's first and last steps (a lost first fix is a discovery race, a
    # lost last one a publisher gone too soon) and the node's own counters
    assert missing == [], '\n'.join(
        [f'person-steps without a fix: {missing} ({len(truth)} person-steps in the FCD, '
         f'{len(got)} fixes received)',
         f'those persons\' first and last steps: '
         f'{ {p: (first[p], max(k for q, k in truth if q == p)) for p, _ in missing} }',
         f'the node\'s last status: {status_values(statuses[-1])}']
        + [line for line in log.splitlines() if 'WARN' in line or 'timer ticks' in line])
    assert sorted(set(got) - set(truth))[:10] == [], 'fixes for no person-step'

    # the node's errors are simulate's on the FCD of the same run
    noisy = tmp_path / 'noisy.xml'
    done = subprocess.run(
        node_executable('gps_error') + ['simulate', '--trajectories', str(fcd),
                                        '--out', str(noisy), '--profile', 'DS5',
                                        '--seed', str(SEED), '--digits', '12'],
        capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    sim = read_fcd(noisy)
    keys = sorted(truth)
    t = np.array([truth[k] for k in keys])
    s = np.array([sim[k] for k in keys])
    n = np.array([got[k] for k in keys])
    err_sim = np.stack(difference(s[:, 0], s[:, 1], t[:, 0], t[:, 1]), axis=1)
    err_node = np.stack(difference(n[:, 0], n[:, 1], t[:, 0], t[:, 1]), axis=1)
    assert np.abs(err_sim).max() > 0.5           # errors were added at all
    np.testing.assert_allclose(err_node, err_sim, atol=1e-6)


@pytest.mark.parametrize('params, expected', [
    ([], "parameter 'sumocfg' is required"),
    (['sumocfg:=/nonexistent/x.sumocfg'], "/nonexistent/x.sumocfg is not a file"),
    (['sumocfg:={plain}'], "parameter 'datum' is required"),
    (['sumocfg:={geo}', 'datum:=[40.0]'], "parameter 'datum': invalid value"),
])
def test_bad_parameters_stop_the_bridge_naming_them(tmp_path, params, expected):
    scenario = build_grid_scenario(tmp_path / 'geo', grid=2, length=50.0, depart_until=4.0)
    plain = tmp_path / 'plain.sumocfg'     # the same net, without its projection
    net = tmp_path / 'plain.net.xml'
    net.write_text(scenario.net.read_text().replace(
        'projParameter="+proj', 'projParameter="!" old="+proj'))
    plain.write_text(scenario.sumocfg.read_text().replace(
        'value="grid.net.xml"', f'value="{net}"'))
    args = ['--ros-args']
    for p in params:
        args += ['-p', p.format(plain=plain, geo=scenario.sumocfg)]
    rc, log = NodeProcess(args, name='gps_error_sumo').wait_exit(timeout=30)
    assert rc == 2 and expected in log, log


def read_fcd_all(path):
    """Return {(kind, id, t): (lat, lon)} of persons and vehicles in a geo FCD file."""
    out = {}
    for ts in ET.parse(path).getroot().iter('timestep'):
        t = round(float(ts.get('time')))
        for a in ts:
            out[(a.tag, a.get('id'), t)] = (float(a.get('y')), float(a.get('x')))
    return out


def test_vehicles_and_navsatfix_truth_are_sumos_positions(tmp_path, peer):
    """vehicle_prefix and output_type navsatfix: one truth message per FCD row, same place."""
    scenario = build_grid_scenario(tmp_path / 'scenario', grid=3, length=60.0,
                                   depart_until=10.0, period=2.0, seed=3,
                                   vehicle_period=3.0)
    assert scenario.vehicles
    ns = unique_ns()
    boxes = {('person', p): peer.collect(NavSatFix, f'{ns}/peds/{p}/fix_truth')
             for p in scenario.persons}
    boxes.update({('vehicle', v): peer.collect(NavSatFix, f'{ns}/cars/{v}/fix_truth')
                  for v in scenario.vehicles})
    fcd = tmp_path / 'fcd.xml'
    bridge = start_bridge(scenario, fcd, 'output_type:=navsatfix',
                          f'person_prefix:={ns}/peds', f'vehicle_prefix:={ns}/cars',
                          'speed:=0.0', 'match_node:=test_peer', 'match_timeout:=10.0')
    try:
        assert peer.spin_until(lambda: bridge.proc.poll() is not None, 120), 'SUMO ran on'
        rc, log = bridge.wait_exit()
        assert rc == 0, log
        peer.spin_for(1.0)
    finally:
        bridge.stop()
    truth = read_fcd_all(fcd)
    assert {k for k, _, _ in truth} == {'person', 'vehicle'}
    got = {}
    for (kind, i), box in boxes.items():
        for m in box:
            key = (kind, i, stamp_ns(m.header.stamp) // NS)
            assert key not in got and m.status.status == 0, key
            got[key] = (m.latitude, m.longitude)
    assert set(got) == set(truth)
    diff = np.array([np.subtract(got[k], truth[k]) for k in truth])
    assert np.abs(diff).max() < 1e-9           # degrees: about 0.1 mm

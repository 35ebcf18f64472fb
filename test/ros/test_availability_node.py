"""Outages in the error node: NO_FIX messages (or none) exactly where the stream says."""

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.model.profiles import builtin_dir, load_profile_file
from gps_error_ros.model.streams import agent_key
from ros_harness import (DATUM, DATUM_ARG, drive, drive_agents, errors, NS, stamp_ns, start,
                         T0, unique_ns)

pytestmark = pytest.mark.integration
SEED = 12
STEPS = 60


def outage_profile(tmp_path):
    """Return a profile path: DS5's axes, and outages one step in five or so."""
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['name'] = 'DS5 with outages'
    raw['availability'] = {'outage_rate': 0.15, 'durations': [[1, 0.4], [3, 0.4], [6, 0.2]]}
    path = tmp_path / 'outages.yaml'
    path.write_text(yaml.safe_dump(raw))
    return path


def test_no_fix_messages_where_the_stream_has_an_outage(tmp_path, peer):
    path = outage_profile(tmp_path)
    model = load_profile_file(path).model()
    key = np_key('')
    mask = model.simulate_fix(key, STEPS, start=T0)[0]
    assert 5 < (~mask).sum() < STEPS - 5, 'the seed gives too few or too many outages'
    ns = unique_ns()
    node = start(ns, f'profile:={path}', DATUM_ARG, f'seed:={SEED}')
    pose_pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pose_pub, f'{ns}/fix', node)
    drive(peer, pose_pub, fixes, STEPS)       # a message every step: fix or NO_FIX
    peer.spin_for(0.3)
    rc, out = node.stop()
    assert rc == 0, out
    assert [stamp_ns(f.header.stamp) for f in fixes] == [k * NS for k in range(T0, T0 + STEPS)]
    status = np.array([f.status.status for f in fixes])
    np.testing.assert_array_equal(status == NavSatStatus.STATUS_NO_FIX, ~mask)
    np.testing.assert_array_equal(status[mask], NavSatStatus.STATUS_FIX)
    # the shutdown line counts every message sent, and the NO_FIX among them apart
    n_fix, n_none = int(mask.sum()), int((~mask).sum())
    assert f'{STEPS} NavSatFix published ({n_fix} with a position, {n_none} NO_FIX)' in out, out
    for f in np.array(fixes, dtype=object)[~mask]:
        assert np.isnan([f.latitude, f.longitude, f.altitude]).all()
        assert f.position_covariance_type == NavSatFix.COVARIANCE_TYPE_UNKNOWN
    # the error process ran on through the outages: the fixes are the stream's
    got = errors([f for f, m in zip(fixes, mask) if m], DATUM[0], DATUM[1])
    expected = model.simulate(key, STEPS, start=T0)[:, 0]     # (steps, agents, 2)
    np.testing.assert_allclose(got, expected[mask], atol=1e-6)


def test_a_silent_crowd_sends_nothing_in_an_outage(tmp_path, peer):
    path = outage_profile(tmp_path)
    model = load_profile_file(path).model()
    names = ['ann', 'bob']
    masks = {n: model.simulate_fix(np_key(n), STEPS, start=T0)[0] for n in names}
    ns = unique_ns()
    node = start(ns, f'profile:={path}', DATUM_ARG, f'seed:={SEED}',
                 'agents:=["ann", "bob"]', 'outage_output:=silent')
    pubs = {n: peer.publisher(PoseStamped, f'{ns}/{n}/pose') for n in names}
    boxes = {n: peer.collect(NavSatFix, f'{ns}/{n}/fix') for n in names}
    for n in names:
        peer.wait_connected(pubs[n], f'{ns}/{n}/fix', node)
    drive_agents(peer, pubs, STEPS)
    peer.set_clock((T0 + STEPS) * NS)
    peer.spin_for(1.0)
    rc, out = node.stop()
    assert rc == 0, out
    for n in names:
        steps = sorted(stamp_ns(f.header.stamp) // NS - T0 for f in boxes[n])
        assert steps == list(np.flatnonzero(masks[n])), n
        assert all(f.status.status == NavSatStatus.STATUS_FIX for f in boxes[n])


def np_key(name):
    return np.array([agent_key(SEED, name)], dtype=np.uint64)

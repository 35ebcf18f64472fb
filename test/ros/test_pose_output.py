"""The error node's fix_pose: each fix as a PoseWithCovarianceStamped in the map frame."""

from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
import numpy as np
import pytest
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.model.geodesy import LocalTangentFrame
from ros_harness import (DATUM, DATUM_ARG, drive, drive_agents, NS, stamp_ns, start, T0,
                         unique_ns)
from test_availability_node import outage_profile

pytestmark = pytest.mark.integration
STEPS = 30
FRAME = LocalTangentFrame(*DATUM)


def _check_pose_is_the_fix(pose, fix):
    """Assert that ``pose`` states what ``fix`` states, in the map frame about the datum."""
    assert pose.header.stamp == fix.header.stamp
    assert pose.header.frame_id == 'map'
    east, north, up = FRAME.to_enu(fix.latitude, fix.longitude, fix.altitude)
    p = pose.pose.pose.position
    # the same point: a micrometre is far below any error the model makes
    np.testing.assert_allclose([p.x, p.y, p.z], [east, north, up], atol=1e-6)
    q = pose.pose.pose.orientation
    assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, 0.0, 1.0)
    cov = np.array(pose.pose.covariance).reshape(6, 6)
    np.testing.assert_array_equal(cov[:3, :3], np.array(fix.position_covariance).reshape(3, 3))
    np.testing.assert_array_equal(cov[3:, :3], 0.0)
    np.testing.assert_array_equal(np.diag(cov)[3:], 1e6)      # orientation unknown


def test_each_fix_comes_as_a_pose_in_the_map_frame(peer):
    ns = unique_ns()
    # conditional: a covariance of its own per fix, which the pose must carry
    node = start(ns, 'profile:=DS5', DATUM_ARG, 'seed:=4', 'pose_frame_id:=map',
                 'covariance_mode:=conditional')
    pose_pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    poses = peer.collect(PoseWithCovarianceStamped, f'{ns}/fix_pose')
    peer.wait_connected(pose_pub, f'{ns}/fix', node)
    assert peer.spin_until(lambda: peer.node.count_publishers(f'{ns}/fix_pose') > 0, 10)
    drive(peer, pose_pub, fixes, STEPS, position=lambda k: (1.3 * (k - T0), 0.0))
    assert peer.spin_until(lambda: len(poses) >= len(fixes), 5.0)
    rc, out = node.stop()
    assert rc == 0, out
    assert len(fixes) == STEPS and len(poses) == STEPS
    by_stamp = {stamp_ns(p.header.stamp): p for p in poses}
    for fix in fixes:
        _check_pose_is_the_fix(by_stamp[stamp_ns(fix.header.stamp)], fix)
    covs = {tuple(f.position_covariance) for f in fixes}
    assert len(covs) > 1, 'conditional mode: expected covariances that change from fix to fix'


def test_a_crowd_in_an_outage_gets_no_pose(tmp_path, peer):
    names = ['ann', 'bob']
    ns = unique_ns()
    node = start(ns, f'profile:={outage_profile(tmp_path)}', DATUM_ARG, 'seed:=12',
                 'agents:=["ann", "bob"]', 'pose_frame_id:=map')
    pubs = {n: peer.publisher(PoseStamped, f'{ns}/{n}/pose') for n in names}
    fixes = {n: peer.collect(NavSatFix, f'{ns}/{n}/fix') for n in names}
    poses = {n: peer.collect(PoseWithCovarianceStamped, f'{ns}/{n}/fix_pose') for n in names}
    for n in names:
        peer.wait_connected(pubs[n], f'{ns}/{n}/fix', node)
    assert drive_agents(peer, pubs, STEPS, lambda k: all(
        fixes[n] and stamp_ns(fixes[n][-1].header.stamp) >= k * NS for n in names)) == []
    peer.spin_for(0.5)
    rc, out = node.stop()
    assert rc == 0, out
    for n in names:
        with_position = [f for f in fixes[n] if f.status.status == NavSatStatus.STATUS_FIX]
        assert 0 < len(with_position) < len(fixes[n]) == STEPS, n   # outages, and fixes
        assert [stamp_ns(p.header.stamp) for p in poses[n]] == \
            [stamp_ns(f.header.stamp) for f in with_position], n
        for pose, fix in zip(poses[n], with_position):
            _check_pose_is_the_fix(pose, fix)


def test_pose_output_from_navsatfix_input_needs_the_datum():
    node = start(unique_ns(), 'input_type:=navsatfix', 'pose_frame_id:=map')
    rc, out = node.wait_exit(timeout=20)
    assert rc != 0, out
    assert "'datum' is required for pose_frame_id" in out, out

"""The error node under bad input: it drops, warns, carries on, never emits NaN."""

import math

import pytest
from rclpy.serialization import serialize_message
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import NavSatFix

from ros_harness import (DATUM_ARG, NodeProcess, NS, Peer, pose_msg, stamp_ns, start,
                         unique_ns)

pytestmark = pytest.mark.integration
T0 = 5000


@pytest.mark.parametrize('crowd', [False, True])
def test_bad_poses_and_clock_reset(crowd):
    ns = unique_ns()
    params = ['--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true',
              '-p', DATUM_ARG, '-p', 'seed:=1']
    prefix = ''
    if crowd:
        params += ['-p', 'agents:=["a","b"]']
        prefix = 'a/'
    node = NodeProcess(params)
    peer = Peer()
    try:
        pub = peer.publisher(PoseStamped, f'{ns}/{prefix}pose')
        fixes = peer.collect(NavSatFix, f'{ns}/{prefix}fix')
        peer.wait_connected(pub, f'{ns}/{prefix}fix', node)

        def step(k, msg=None):
            pub.publish(msg if msg is not None else pose_msg(k * NS))
            peer.set_clock(k * NS)
            peer.spin_for(0.05)

        for k in range(T0, T0 + 5):
            step(k)
        bad = []
        for value in (math.nan, math.inf, -math.inf):
            m = pose_msg((T0 + 5) * NS)
            m.pose.position.x = value
            bad.append(m)
        m = pose_msg((T0 + 5) * NS)
        m.pose.orientation.w = 0.0
        bad.append(m)
        bad.append(pose_msg((T0 + 9999) * NS))        # far in the future
        bad.append(pose_msg((T0 + 2) * NS))           # out of order
        whole = serialize_message(pose_msg((T0 + 5) * NS))
        bad += [whole[:10], whole[:40]]              # truncated CDR bytes
        for m in bad:
            pub.publish(m)
        peer.spin_for(0.3)
        for k in range(T0 + 5, T0 + 10):
            step(k)
        peer.spin_for(1.0)
        before_reset = len(fixes)
        for k in range(T0 - 100, T0 - 95):            # simulator reset: time goes back
            step(k)
        peer.spin_for(1.0)
        rc, out = node.stop()
        assert rc == 0, out
    finally:
        node.stop()
        peer.destroy()
    stamps = [stamp_ns(f.header.stamp) for f in fixes]
    assert all(math.isfinite(v) for f in fixes
               for v in (f.latitude, f.longitude, f.altitude, *f.position_covariance))
    # the node counts steps from the first clock reading it sees, which may
    # be the second tick if the first went out before /clock was matched
    first = stamps[0] // NS
    assert T0 <= first <= T0 + 2
    # and says so, with what makes the first step fixed
    assert f'the error streams begin at ROS time {first:.3f} s (the first clock ' \
        'reading: set start_time' in out, out
    assert stamps[:before_reset] == [k * NS for k in range(first, T0 + 10)]
    after = stamps[before_reset:]
    assert after and all((T0 - 100) * NS <= s < (T0 - 95) * NS for s in after)
    assert '1 clock resets' in out and '1 stamped in the future' in out
    assert 'went backwards' in out
    if crowd:     # parsed by the node; rclpy never hands a single agent truncated ones
        assert 'dropped 2 truth message(s) that could not be parsed' in out


def test_clock_ahead_of_the_poses_is_named_with_the_parameter_to_raise():
    ns = unique_ns()
    node = start(ns, DATUM_ARG, 'seed:=1')
    peer = Peer()
    try:
        pub = peer.publisher(PoseStamped, f'{ns}/pose')
        fixes = peer.collect(NavSatFix, f'{ns}/fix')
        peer.wait_connected(pub, f'{ns}/fix', node)
        for k in range(T0, T0 + 12):
            peer.set_clock(k * NS)                          # the clock leads
            pub.publish(pose_msg((k - 3) * NS, east=float(k)))   # by 3 s
            peer.spin_for(0.05)
        peer.spin_for(0.5)
        rc, out = node.stop()
    finally:
        node.stop()
        peer.destroy()
    assert rc == 0, out
    assert 'raise max_pose_age' in out, out
    assert len(fixes) < 12


@pytest.mark.parametrize('crowd', [False, True])
def test_five_seconds_of_nan_poses_are_named_as_such(crowd):
    """No fix and no NO_FIX while the truth is NaN; the warning names the poses, not the clock."""
    ns = unique_ns()
    args = [DATUM_ARG, 'seed:=1'] + (['agents:=["a"]'] if crowd else [])
    prefix = 'a/' if crowd else ''
    node = start(ns, *args)
    peer = Peer()
    try:
        pub = peer.publisher(PoseStamped, f'{ns}/{prefix}pose')
        fixes = peer.collect(NavSatFix, f'{ns}/{prefix}fix')
        peer.wait_connected(pub, f'{ns}/{prefix}fix', node)
        for k in range(T0, T0 + 20):
            m = pose_msg(k * NS)
            if T0 + 5 <= k < T0 + 10:
                m.pose.position.x = math.nan
            pub.publish(m)
            peer.set_clock(k * NS)
            peer.spin_for(0.05)
        peer.spin_for(1.0)
        rc, out = node.stop()
    finally:
        node.stop()
        peer.destroy()
    assert rc == 0, out
    stamps = {stamp_ns(f.header.stamp) // NS for f in fixes}
    # the last valid pose is held for max_pose_age (1 s); then nothing until valid truth
    assert not stamps & set(range(T0 + 6, T0 + 10)), sorted(stamps)
    assert set(range(T0 + 10, T0 + 20)) <= stamps, sorted(stamps)
    assert 'truth was invalid' in out and 'raise max_pose_age' not in out, out


@pytest.mark.parametrize('crowd, policy', [(False, 'warn'), (True, 'warn'), (True, 'refuse')])
def test_a_pose_in_another_frame_is_named_and_counted(crowd, policy):
    """Poses stamped base_link: one warning naming the frame, a count on /diagnostics."""
    from diagnostic_msgs.msg import DiagnosticArray
    from ros_harness import node_statuses, status_values
    ns = unique_ns()
    args = [DATUM_ARG, 'seed:=1', f'other_frames:={policy}'] + \
        (['agents:=["a"]'] if crowd else [])
    prefix = 'a/' if crowd else ''
    node = start(ns, *args)
    peer = Peer()
    try:
        box = peer.collect(DiagnosticArray, '/diagnostics')
        pub = peer.publisher(PoseStamped, f'{ns}/{prefix}pose')
        fixes = peer.collect(NavSatFix, f'{ns}/{prefix}fix')
        peer.wait_connected(pub, f'{ns}/{prefix}fix', node)
        for k in range(T0, T0 + 8):
            m = pose_msg(k * NS)
            m.header.frame_id = 'base_link'
            pub.publish(m)
            peer.set_clock(k * NS)
            peer.spin_for(0.05)
        mine = f'{ns}/gps_error_node'

        def counted():
            statuses = node_statuses(box, mine)
            return statuses and int(status_values(statuses[-1]).get(
                'truth in another frame than truth_frame', 0)) == 8
        assert peer.spin_until(counted, 10), node_statuses(box, mine)[-1:]
        rc, out = node.stop()
    finally:
        node.stop()
        peer.destroy()
    assert rc == 0, out
    assert out.count("truth pose in frame 'base_link', expected 'map'") == 1, out
    if policy == 'warn':
        assert len(fixes) >= 6           # taken as they are
    else:
        assert len(fixes) == 0           # refused: no truth, no fix

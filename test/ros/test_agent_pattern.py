"""agent_pattern: agents served as their topics appear, released when they leave."""

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.profiles import load_profile
from gps_error_ros.model.streams import agent_key
from ros_harness import (DATUM, DATUM_ARG, errors, node_statuses, NodeProcess, NS, Peer,
                         pose_msg, stamp_ns, status_values, unique_ns)

pytestmark = pytest.mark.integration
T0 = 3000
SEED = 31
TIMEOUT = 3.0


def pattern_node(ns, *extra):
    args = ['--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true', '-p', DATUM_ARG,
            '-p', f'seed:={SEED}', '-p', 'max_pose_age:=3.0', '-p', 'profile:=DS7',
            '-p', f'agent_pattern:={ns}/peds/*/pose', '-p', f'agent_timeout:={TIMEOUT}']
    for e in extra:
        args += ['-p', e]
    return NodeProcess(args)


def flat(status):
    """Return {key: value} of a diagnostics status, with its level and message."""
    return dict(status_values(status), level=status.level[0], message=status.message)


class Crowd:
    """The peer's side: pose publishers that come and go, one step at a time."""

    def __init__(self, peer, ns):
        self.peer, self.ns = peer, ns
        self.pubs, self.fixes = {}, {}
        self.sent = {}               # agent -> steps whose pose was sent

    def come(self, name):
        topic = f'{self.ns}/peds/{name}/pose'
        self.pubs[name] = self.peer.publisher(PoseStamped, topic)
        if name not in self.fixes:
            self.fixes[name] = self.peer.collect(NavSatFix, f'{self.ns}/peds/{name}/fix')
        assert self.peer.spin_until(lambda: self.pubs[name].get_subscription_count() > 0, 15), \
            f'{name} was not discovered'
        self.peer.spin_for(0.3)

    def leave(self, name):
        self.peer.node.destroy_publisher(self.pubs.pop(name))

    def step(self, k, quiet=()):
        for name, pub in self.pubs.items():
            if name not in quiet:
                pub.publish(pose_msg(k * NS, 5.0 * len(name), 2.0))
                self.sent.setdefault(name, []).append(k)
        self.peer.set_clock(k * NS)
        want = (k - 1) * NS
        waiting = [n for n in self.pubs if n not in quiet and (k - 1) in self.sent[n]]
        self.peer.spin_until(lambda: all(
            self.fixes[n] and stamp_ns(self.fixes[n][-1].header.stamp) >= want
            for n in waiting), 5)


def test_agents_come_go_and_come_back_on_their_streams():
    ns = unique_ns()
    node = pattern_node(ns)
    peer = Peer()
    try:
        diag = peer.collect(DiagnosticArray, '/diagnostics')
        mine = []

        def status_seen(pred):
            mine[:] = node_statuses(diag, f'{ns}/gps_error_node')
            return bool(mine) and pred(flat(mine[-1]))
        # the node has subscribed to /clock and started (its status flows)
        assert peer.spin_until(lambda: status_seen(lambda s: True), 20), node.stop()[1]
        assert peer.spin_until(lambda: any(
            e.node_namespace == ns for e in peer.node.get_subscriptions_info_by_topic('/clock')),
            10)
        peer.spin_for(0.5)
        peer.set_clock(T0 * NS)     # the node's first step: every agent counts from it
        assert peer.spin_until(lambda: status_seen(
            lambda s: float(s['ROS time (s)']) == T0 and int(s['timer ticks']) >= 1), 10)
        wrong = peer.publisher(Odometry, f'{ns}/peds/odo/pose')    # wrong type: not served
        crowd = Crowd(peer, ns)
        crowd.come('anna')
        crowd.come('bert')
        for k in range(T0 + 1, T0 + 61):
            if k == T0 + 15:
                crowd.come('cleo')
            if k == T0 + 22:
                crowd.leave('bert')
            if k == T0 + 30:        # bert stale for longer than agent_timeout, no publisher
                assert peer.spin_until(
                    lambda: peer.node.count_publishers(f'{ns}/peds/bert/fix') == 0, 10), \
                    'bert was not released'
                assert peer.spin_until(lambda: status_seen(
                    lambda s: s['agents released'] == '1'), 5)
            if k == T0 + 44:
                # anna has been quiet (publisher kept) longer than agent_timeout:
                # stale, not released; the status says so
                assert peer.spin_until(lambda: status_seen(
                    lambda s: s['agents stale'] == '1' and s['level'] == 1), 5), mine[-1]
                assert peer.node.count_publishers(f'{ns}/peds/anna/fix') == 1
                crowd.come('bert')              # bert comes back
            crowd.step(k, quiet=('anna',) if T0 + 36 <= k < T0 + 44 else ())
        peer.spin_for(1.0)
        rc, log = node.stop()
        assert rc == 0, log
        assert f'{ns}/peds/odo/pose' in log and 'not served' in log, log
        assert peer.node.count_publishers(f'{ns}/peds/odo/fix') == 0
        del wrong
    finally:
        node.stop()
        peer.destroy()
    model = load_profile('DS7').model()
    n = 61
    for name, box in crowd.fixes.items():
        stamps = [stamp_ns(f.header.stamp) // NS for f in box]
        # one fix per step whose pose was sent, none twice; after the truth
        # stops, up to max_pose_age (3) steps on the held truth, none beyond
        sent = set(crowd.sent[name]) - {T0 + 60}
        held = {s + d for s in sent for d in (1, 2, 3) if s + 1 not in sent}
        assert sorted(stamps) == sorted(set(stamps)), name
        assert sent <= set(stamps) - {T0 + 60} <= sent | held, (
            name, sorted(sent ^ set(stamps)))
        truth_lat, truth_lon = _truth(5.0 * len(name), 2.0)
        got = errors(box, truth_lat, truth_lon)
        expected = model.simulate(agent_key(SEED, name), n, start=T0)[:, 0]
        np.testing.assert_allclose(got, expected[np.array(stamps) - T0], atol=1e-6,
                                   err_msg=name)


def _truth(east, north):
    from gps_error_ros.model.geodesy import LocalTangentFrame
    lat, lon, _ = LocalTangentFrame(*DATUM).to_geodetic(east, north, 0.0)
    return lat, lon


@pytest.mark.parametrize('params, expected', [
    (['agent_pattern:=/peds/pose'], 'exactly one *'),
    (['agent_pattern:=/peds/*'], 'a segment after the *'),
    (['agent_pattern:=/peds/*/pose', 'agents:=["a"]'], 'one way of naming'),
])
def test_a_bad_pattern_stops_the_node_naming_it(params, expected):
    args = ['--ros-args', '-r', f'__ns:={unique_ns()}', '-p', DATUM_ARG]
    for p in params:
        args += ['-p', p]
    rc, out = NodeProcess(args).wait_exit()
    assert rc == 2 and 'agent_pattern' in out and expected in out, out

"""/diagnostics from both nodes, and the README's topic table against the live graph."""

import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
import pytest
from rclpy.qos import ReliabilityPolicy
from sensor_msgs.msg import NavSatFix

from gps_error_ros.ros.topics import NODE_TOPICS
from ros_harness import (DATUM_ARG, node_statuses, NodeProcess, NS, Peer, pose_msg, start,
                         stamp_ns, status_values, unique_ns)

pytestmark = pytest.mark.integration
T0 = 4000


def test_error_node_status_says_what_was_skipped_and_keeps_coming_on_a_paused_clock():
    ns = unique_ns()
    node = start(ns, DATUM_ARG, 'seed:=3')
    peer = Peer()
    try:
        box = peer.collect(DiagnosticArray, '/diagnostics')
        fixes = peer.collect(NavSatFix, f'{ns}/fix')
        pose = peer.publisher(PoseStamped, f'{ns}/pose')
        mine = f'{ns}/gps_error_node'
        assert peer.spin_until(lambda: node_statuses(box, mine), 20), node.stop()[1]
        first = node_statuses(box, mine)[-1]
        assert first.name == 'gps_error_node: fixes'
        assert first.level == DiagnosticStatus.OK, first
        assert status_values(first)['profile'] == 'DS5' and status_values(first)['seed'] == '3'
        # the clock paused (never started): the status still comes once a second
        n0 = len(node_statuses(box, mine))
        peer.spin_for(2.6)
        assert len(node_statuses(box, mine)) - n0 >= 2
        peer.wait_connected(pose, f'{ns}/fix', node)
        for k in range(T0, T0 + 6):          # steps without truth: skipped, WARN
            peer.set_clock(k * NS)
            peer.spin_for(0.1)
        assert peer.spin_until(lambda: node_statuses(box, mine)[-1].level == DiagnosticStatus.WARN
                               and 'skipped without truth' in node_statuses(box, mine)[-1].message,
                               5), node_statuses(box, mine)[-1]
        for k in range(T0 + 6, T0 + 12):     # truth flows: fixes, OK again
            pose.publish(pose_msg(k * NS))
            peer.set_clock(k * NS)
            peer.spin_until(lambda: fixes and stamp_ns(fixes[-1].header.stamp) >= k * NS, 3)
        peer.spin_for(1.2)
        # truth flows: the status returns to OK once a period passes without trouble
        for k in range(T0 + 12, T0 + 16):
            pose.publish(pose_msg(k * NS))
            peer.set_clock(k * NS)
            peer.spin_for(0.6)
        peer.spin_for(1.3)                   # a status after the last fix
        last = node_statuses(box, mine)[-1]
        assert last.level == DiagnosticStatus.OK, last
        v = status_values(last)
        assert int(v['fixes published']) == len(fixes) > 0
        assert int(v['steps skipped without truth']) >= 5
        assert float(v['ROS time (s)']) >= T0 + 14
    finally:
        rc, out = node.stop()
        peer.destroy()
    assert rc == 0, out


def test_calibration_node_status_waits_for_both_inputs(tmp_path):
    ns = unique_ns()
    node = NodeProcess(['--ros-args', '-r', f'__ns:={ns}', '-p', DATUM_ARG,
                        '-p', f'output:={tmp_path / "p.yaml"}'], name='gps_calibration_node')
    peer = Peer()
    try:
        box = peer.collect(DiagnosticArray, '/diagnostics')
        mine = f'{ns}/gps_calibration_node'
        assert peer.spin_until(lambda: node_statuses(box, mine), 20), node.stop()[1]
        status = node_statuses(box, mine)[-1]
        assert status.name == 'gps_calibration_node: calibration'
        assert status.level == DiagnosticStatus.WARN and 'waiting for data' in status.message
        assert status_values(status)['fixes received'] == '0'
        assert status_values(status)['output'] == str(tmp_path / 'p.yaml')
    finally:
        rc, out = node.stop()
        peer.destroy()
    assert rc == 0, out


def _table(node):
    return {e.name: e for e in NODE_TOPICS[node]}


def _reliability(qos):
    if isinstance(qos, dict):
        return {q.reliability for q in qos.values()}
    return {qos.reliability}


@pytest.mark.parametrize('node_name', ['gps_error_node', 'gps_calibration_node'])
def test_the_topic_table_is_what_the_running_node_shows(node_name, tmp_path):
    ns = unique_ns()
    args = ['--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true', '-p', DATUM_ARG]
    if node_name == 'gps_calibration_node':
        args += ['-p', f'output:={tmp_path / "p.yaml"}']
    node = NodeProcess(args, name=node_name)
    peer = Peer()
    table = _table(node_name)
    subs = {'pose': f'{ns}/pose', '/clock': '/clock'}
    pubs = {'/diagnostics': '/diagnostics'}
    if node_name == 'gps_error_node':
        pubs['fix'] = f'{ns}/fix'
    else:
        subs['fix'] = f'{ns}/fix'
    seen = {}

    def endpoints():
        for key, topic in subs.items():
            seen[key] = [e for e in peer.node.get_subscriptions_info_by_topic(topic)
                         if e.node_namespace == ns]
        for key, topic in pubs.items():
            seen[key] = [e for e in peer.node.get_publishers_info_by_topic(topic)
                         if e.node_namespace == ns]
        return all(seen.values())
    try:
        assert peer.spin_until(endpoints, 20), (seen, node.stop()[1])
        for key, found in seen.items():
            entry = table[key]
            (endpoint,) = found
            want_type = entry.type.replace('/', '/msg/') if key != 'pose' else \
                'geometry_msgs/msg/PoseStamped'
            assert endpoint.topic_type == want_type, (key, endpoint.topic_type)
            assert endpoint.qos_profile.reliability in _reliability(entry.qos), key
            assert entry.direction == ('in' if key in subs else 'out'), key
        if node_name == 'gps_calibration_node':
            deadline = time.monotonic() + 10
            services = []
            while time.monotonic() < deadline and f'{ns}/gps_calibration_node/calibrate' \
                    not in services:
                services = [n for n, _ in peer.node.get_service_names_and_types()]
                peer.spin_for(0.2)
            assert f'{ns}/gps_calibration_node/calibrate' in services
            assert table['~/calibrate'].type == 'std_srvs/Trigger'
    finally:
        rc, out = node.stop()
        peer.destroy()
    assert rc == 0, out
    assert ReliabilityPolicy.BEST_EFFORT in _reliability(table['pose'].qos)

"""gps_calibration_node as a real process: topics in, service, shutdown."""

import csv
import math
import signal

import numpy as np
import pytest
from rclpy.duration import Duration
from sensor_msgs.msg import NavSatFix, NavSatStatus
from std_srvs.srv import Trigger

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.model.geodesy import offset
from gps_error_ros.model.profiles import load_profile_file
from ros_harness import NodeProcess, Peer, replay_calibration_node, stamp, unique_ns

pytestmark = pytest.mark.integration
LAT, LON = 48.137, 11.575


def fix_msg(t, lat, lon, status=NavSatStatus.STATUS_FIX):
    m = NavSatFix()
    m.header.stamp = stamp(int(t * 1e9))
    m.status.status = status
    m.latitude, m.longitude = lat, lon
    return m


def test_calibrate_service_then_sigterm_keeps_everything(tmp_path):
    ns = unique_ns()
    out = tmp_path / 'phone.yaml'
    node = NodeProcess(['--ros-args', '-r', f'__ns:={ns}',
                        '-p', 'input_type:=navsatfix', '-p', f'output:={out}',
                        '-p', 'order:=1', '-p', 'input_reliability:=reliable'],
                       name='gps_calibration_node')
    peer = Peer()
    try:
        # Reliable, with the whole burst kept at this end: best effort (the
        # default) loses messages of a burst that outruns a node on a loaded
        # machine, and so does a reliable writer keeping fewer than the node
        # has yet to acknowledge. What is measured is the node's keeping
        # everything that reached it.
        n = 800
        fix_pub = peer.publisher(NavSatFix, f'{ns}/fix', depth=n + 10)
        truth_pub = peer.publisher(NavSatFix, f'{ns}/fix_truth', depth=2 * n + 10)
        client = peer.node.create_client(Trigger, f'{ns}/gps_calibration_node/calibrate')
        assert peer.spin_until(lambda: fix_pub.get_subscription_count() > 0
                               and truth_pub.get_subscription_count() > 0, 20)
        assert client.wait_for_service(timeout_sec=10)
        peer.spin_for(0.5)
        model = ARErrorModel(AxisParams(0.0, (0.9,), 0.7), AxisParams(0.1, (0.6,), 0.4))
        err = model.simulate(streams.agent_key(5), n)[:, 0]
        lat, lon = offset(LAT, LON, err[:, 0], err[:, 1])
        for i in range(n):
            t = 100.0 + i
            truth_pub.publish(fix_msg(t - 0.5, LAT, LON))
            truth_pub.publish(fix_msg(t + 0.5, LAT, LON))
            fix_pub.publish(fix_msg(t, float(lat[i]), float(lon[i])))
            if i % 10 == 9:
                peer.spin_for(0.01)
        fix_pub.publish(fix_msg(2000.0, LAT, LON, NavSatStatus.STATUS_NO_FIX))
        fix_pub.publish(fix_msg(2001.0, math.nan, LON))
        # all of it in the node's queues (not necessarily taken yet: the fit takes it)
        for pub in (fix_pub, truth_pub):
            assert pub.wait_for_all_acked(Duration(seconds=30))
        future = client.call_async(Trigger.Request())
        assert peer.spin_until(future.done, 20)
        resp = future.result()
        assert resp.success, resp.message
        assert 'AR(1)' in resp.message and '1 no fix' in resp.message \
            and '1 invalid' in resp.message
        p = load_profile_file(out)
        assert abs(p.axes['north'].phi[0] - 0.9) < 5 * np.sqrt((1 - 0.81) / n)
        out.unlink()
        node.proc.send_signal(signal.SIGTERM)
        rc, log = node.wait_exit(timeout=20)
        assert rc == 0, log
        assert out.exists(), log             # rewritten at shutdown
        with open(tmp_path / 'phone.fixes.csv') as f:
            assert len(list(csv.DictReader(f))) == n
        with open(tmp_path / 'phone.truth.csv') as f:
            # t + 0.5 of one step is t - 0.5 of the next: duplicates dropped
            assert len(list(csv.DictReader(f))) == n + 1
        with open(tmp_path / 'phone.trace.csv') as f:
            assert len(list(csv.DictReader(f))) == n
    finally:
        node.stop()
        peer.destroy()


def test_too_little_data_is_refused_but_kept(tmp_path):
    ns = unique_ns()
    out = tmp_path / 'few.yaml'
    node = NodeProcess(['--ros-args', '-r', f'__ns:={ns}', '-p', 'input_type:=navsatfix',
                        '-p', f'output:={out}'], name='gps_calibration_node')
    peer = Peer()
    try:
        fix_pub = peer.publisher(NavSatFix, f'{ns}/fix')
        truth_pub = peer.publisher(NavSatFix, f'{ns}/fix_truth')
        assert peer.spin_until(lambda: fix_pub.get_subscription_count() > 0
                               and truth_pub.get_subscription_count() > 0, 20)
        peer.spin_for(0.5)
        for i in range(5):
            truth_pub.publish(fix_msg(10.0 + i, LAT, LON))
            fix_pub.publish(fix_msg(10.2 + i, LAT, LON))
        peer.spin_for(0.5)
        rc, log = node.stop()
        assert rc == 0, log
        assert 'too few' in log
        assert not out.exists()
        with open(tmp_path / 'few.fixes.csv') as f:
            assert len(list(csv.DictReader(f))) == 5
    finally:
        node.stop()
        peer.destroy()


def test_pose_input_needs_datum():
    node = NodeProcess(['--ros-args', '-r', f'__ns:={unique_ns()}'],
                       name='gps_calibration_node')
    rc, out = node.wait_exit()
    assert rc == 2 and "'datum'" in out


def test_bag_replayed_on_clock_gives_the_offline_fit(tmp_path):
    """The node and `gps_error calibrate` share the fitting code: same bag, same profile."""
    from gps_error_ros.cli import main as cli_main
    from gps_error_ros.ros.bag_play import play
    from bag_helpers import write_walk_bag

    datum = (40.0, -74.0, 0.0)
    n = 600
    model = ARErrorModel(AxisParams(0.2, (1.3, -0.4), 0.5), AxisParams(0.0, (0.7,), 0.6))
    err = model.simulate(streams.agent_key(77), n)[:, 0]
    bag = tmp_path / 'rec'
    write_walk_bag(bag, 'mcap', datum, err, 500.0 + np.arange(n), truth_rate=2.0)
    offline = tmp_path / 'offline.yaml'
    assert cli_main(['calibrate', str(bag), '-o', str(offline), '--truth-topic',
                     '/truth', '--datum', '40.0,-74.0,0.0', '--name', 'x']) == 0

    ns = unique_ns()
    live = tmp_path / 'live.yaml'
    node = replay_calibration_node(ns, live, 'name:=x')
    peer = Peer()
    try:
        played = play(bag, rate=100.0, wait_for_subscribers=1, node=peer.node)
        assert played == n + 2 * (n + 1)
        peer.spin_for(1.0)
        rc, log = node.stop()
        assert rc == 0, log
    finally:
        node.stop()
        peer.destroy()
    a, b = load_profile_file(offline), load_profile_file(live)
    assert b.fit['samples'] == n
    for ax in ('north', 'east'):
        np.testing.assert_allclose(b.axes[ax].phi, a.axes[ax].phi, atol=1e-9)
        assert b.axes[ax].sigma_w == pytest.approx(a.axes[ax].sigma_w, abs=1e-9)


def test_lost_messages_are_reported_not_fitted_silently(tmp_path):
    """A stream with 5 % of its fixes missing: the fit says the data look damaged."""
    from gps_error_ros.ros.bag_play import play
    from bag_helpers import write_walk_bag

    n = 600
    model = ARErrorModel(AxisParams(0.2, (0.9,), 0.5), AxisParams(0.0, (0.7,), 0.6))
    err = model.simulate(streams.agent_key(8), n)[:, 0]
    keep = np.arange(n) % 20 != 7
    bag = tmp_path / 'holed'
    write_walk_bag(bag, 'mcap', (40.0, -74.0, 0.0), err[keep], 500.0 + np.arange(n)[keep],
                   truth_rate=2.0)
    ns = unique_ns()
    out = tmp_path / 'holed.yaml'
    node = replay_calibration_node(ns, out)
    peer = Peer()
    try:
        play(bag, rate=100.0, wait_for_subscribers=1, node=peer.node)
        peer.spin_for(1.0)
        rc, log = node.stop()
    finally:
        node.stop()
        peer.destroy()
    assert rc == 0, log
    assert out.exists() and 'look damaged' in log and '30 of 600 steps missing' in log, log


def test_a_fit_takes_what_reached_the_node_but_was_not_yet_taken(tmp_path):
    # the node in this process, never spun: everything it holds at the fit
    # was taken by the fit itself from the subscriptions' queues
    from rclpy.parameter import Parameter
    from gps_error_ros.ros.calibration_node import GpsCalibrationNode
    ns = unique_ns()
    out = tmp_path / 'queued.yaml'
    node = GpsCalibrationNode(namespace=ns, parameter_overrides=[
        Parameter('input_type', value='navsatfix'), Parameter('output', value=str(out)),
        Parameter('order', value=1), Parameter('input_reliability', value='reliable')])
    peer = Peer()
    try:
        n = 300
        fix_pub = peer.publisher(NavSatFix, f'{ns}/fix', depth=n)
        truth_pub = peer.publisher(NavSatFix, f'{ns}/fix_truth', depth=n + 1)
        assert peer.spin_until(lambda: fix_pub.get_subscription_count() > 0
                               and truth_pub.get_subscription_count() > 0, 20)
        rng = np.random.default_rng(3)
        for i in range(n):
            truth_pub.publish(fix_msg(100.0 + i - 0.5, LAT, LON))
            d = 1e-5 * rng.standard_normal(2)
            fix_pub.publish(fix_msg(100.0 + i, LAT + d[0], LON + d[1]))
        truth_pub.publish(fix_msg(100.0 + n, LAT, LON))
        for pub in (fix_pub, truth_pub):
            assert pub.wait_for_all_acked(Duration(seconds=30))
        assert not node.fixes and not node.truth
        ok, message = node.calibrate()
        assert ok, message
        assert len(node.fixes) == n and len(node.truth) == n + 1, message
        assert f'{n} of {n} fixes paired' in message, message
        assert node.take_pending() == 0
    finally:
        peer.destroy()
        node.destroy_node()

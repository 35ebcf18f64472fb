"""``gps_error_record``: the node's fixes and the truth into a bag, without ros2cli."""

from geometry_msgs.msg import PoseStamped
import numpy as np
import pytest
from sensor_msgs.msg import NavSatFix

from gps_error_ros.traces.bag_io import read_fix_and_truth, read_messages
from ros_harness import DATUM, DATUM_ARG, drive, NodeProcess, start, stamp_ns, unique_ns

pytestmark = pytest.mark.integration


def test_what_the_node_publishes_is_in_the_bag_and_reads_back(tmp_path, peer):
    ns = unique_ns()
    node = start(ns, 'profile:=DS5', DATUM_ARG, 'seed:=4')
    pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pub, f'{ns}/fix', node)
    bag = tmp_path / 'walk'
    rec = NodeProcess([str(bag), f'{ns}/fix', f'{ns}/pose', '--use-sim-time'],
                      name='gps_error_record')
    assert rec.wait_output('recording'), rec.stop()[1]
    # the recorder's two subscriptions matched before the first step
    assert peer.spin_until(lambda: pub.get_subscription_count() >= 2
                           and peer.node.count_subscribers(f'{ns}/fix') >= 2, 10.0)
    drive(peer, pub, fixes, 12, position=lambda k: (1.3 * k, 0.0))
    peer.spin_for(0.5)
    rc, out = rec.stop()
    assert rc == 0, out
    assert f'recorded 12 on {ns}/fix, 12 on {ns}/pose' in out, out
    node.stop()
    got, truth, skipped = read_fix_and_truth(bag, f'{ns}/fix', f'{ns}/pose', DATUM)
    assert skipped == 0 and len(truth['t']) == 12
    np.testing.assert_array_equal(got['t'], [stamp_ns(f.header.stamp) / 1e9 for f in fixes])
    np.testing.assert_array_equal(got['lat'], [f.latitude for f in fixes])
    # stamped on the ROS clock of /clock: the bag's times are the simulated seconds
    times = [ts for ts, _ in read_messages(bag, [f'{ns}/fix'])[f'{ns}/fix']]
    assert min(times) >= stamp_ns(fixes[0].header.stamp)


def test_a_bag_that_exists_is_not_overwritten(tmp_path):
    (tmp_path / 'walk').mkdir()
    rec = NodeProcess([str(tmp_path / 'walk'), '/fix'], name='gps_error_record')
    rc, out = rec.wait_exit()
    assert rc != 0 and 'exists' in out and 'no recording is overwritten' in out

"""The error node's vel topic: the truth's velocity, lagged, plus the agent's own error."""

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import PoseStamped, TwistWithCovarianceStamped
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.profiles import builtin_dir, load_profile_file
from gps_error_ros.model.streams import agent_key
from ros_harness import DATUM_ARG, drive, NS, stamp_ns, start, T0, unique_ns

pytestmark = pytest.mark.integration
SEED = 8
STEPS = 40
SPEED = 1.4          # m/s east


# without a table, and with one: the error's SD at 1.4 m/s is 0.3 + 0.4 (0.1 - 0.3) = 0.22
@pytest.mark.parametrize('table, sd', [(None, 0.15), ([[1.0, 0.3], [2.0, 0.1]], 0.22)])
def test_vel_is_the_lagged_truth_velocity_plus_the_stream(tmp_path, peer, table, sd):
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['velocity'] = {'sigma': 0.15, 'phi': 0.7, 'lag_s': 0.4, 'standstill': 0.0}
    if table is not None:
        raw['velocity']['sigma_by_speed'] = table
    path = tmp_path / 'velocity.yaml'
    path.write_text(yaml.safe_dump(raw))
    ns = unique_ns()
    node = start(ns, f'profile:={path}', DATUM_ARG, f'seed:={SEED}', 'max_pose_age:=3.0')
    pose_pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    vels = peer.collect(TwistWithCovarianceStamped, f'{ns}/vel')
    peer.wait_connected(pose_pub, f'{ns}/fix', node)
    assert peer.spin_until(lambda: peer.node.count_publishers(f'{ns}/vel') > 0, 10)
    drive(peer, pose_pub, fixes, STEPS, position=lambda k: (SPEED * (k - T0), 0.0))
    peer.spin_for(0.5)
    rc, out = node.stop()
    assert rc == 0, out
    velocity = load_profile_file(path).velocity
    w = velocity.errors(np.array([agent_key(SEED, '')], dtype=np.uint64), STEPS, T0)[:, 0]
    stamps = [stamp_ns(v.header.stamp) // NS for v in vels]
    # the chord centred at t - 0.4 s ends at t (never later): from the second step
    # on the truth covers it, and every fix then has a vel
    assert stamps == list(range(T0 + 1, T0 + STEPS)), stamps
    got = np.array([[v.twist.twist.linear.x, v.twist.twist.linear.y] for v in vels])
    expected = np.array([SPEED, 0.0]) + w[1:] * sd / 0.15
    # the chord is measured on the ellipsoid, the walk 23 m below it (the datum's
    # height): 1.4 m/s comes out 3.6 ppm longer, 5 micrometres per second
    np.testing.assert_allclose(got, expected, atol=2e-5)
    cov = np.array(vels[0].twist.covariance).reshape(6, 6)
    # (the table is read at the chord's speed, 3.6 ppm above 1.4 m/s)
    assert np.diag(cov)[:3] == pytest.approx([sd ** 2] * 3, rel=1e-4) and np.diag(cov)[3] == 1e6
    # gps_error simulate reports the same speed and course for the same walk
    from gps_error_ros.model.geodesy import LocalTangentFrame
    from gps_error_ros.sim.velocity_sim import speed_and_course
    from ros_harness import DATUM
    t = np.arange(T0, T0 + STEPS, dtype=float)
    lat, lon, _ = LocalTangentFrame(*DATUM).to_geodetic(SPEED * (t - T0), 0.0 * t, 0.0 * t)
    speed, course, _, _ = speed_and_course(
        velocity, SEED, {'t': t, 'agent': [''] * STEPS, 'truth_lat': np.asarray(lat),
                         'truth_lon': np.asarray(lon)}, T0, 1.0)
    assert np.isnan(speed[0])            # nor does simulate report one at the first step
    np.testing.assert_allclose(speed[1:], np.hypot(got[:, 0], got[:, 1]), atol=2e-5)
    np.testing.assert_allclose(course[1:], np.degrees(np.arctan2(got[:, 0], got[:, 1])) % 360,
                               atol=1e-3)

"""The error node's vel topic: the truth's velocity, lagged, plus the agent's own error."""

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import PoseStamped, TwistWithCovarianceStamped
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.profiles import builtin_dir, load_profile_file
from gps_error_ros.model.streams import agent_key
from gps_error_ros.model.velocity import velocity_from_dict
from ros_harness import DATUM_ARG, drive, NS, stamp_ns, start, T0, unique_ns

pytestmark = pytest.mark.integration
SEED = 8
STEPS = 40
SPEED = 1.4          # m/s east


# without a table, and with one: the error's SD at 1.4 m/s is 0.3 + 0.4 (0.1 - 0.3) = 0.22,
# with the agent's own scale of it and bursts (the published SD stays the population's);
# and a course that lags more than the speed, on a walk that turns, its speed 0.1 m/s low
@pytest.mark.parametrize('table, sd, course_lag', [(None, 0.15, None),
                                                   ([[1.0, 0.3], [2.0, 0.1]], 0.22, None),
                                                   (None, 0.15, 1.0)])
def test_vel_is_the_lagged_truth_velocity_plus_the_stream(tmp_path, peer, table, sd, course_lag):
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['velocity'] = {'sigma': 0.15, 'phi': 0.7, 'lag_s': 0.4, 'standstill': 0.0}
    if table is not None:
        raw['velocity']['sigma_by_speed'] = table
        raw['velocity'].update(scale_sd_log=0.5, burst_share=0.2, burst_ratio=4.0)
    if course_lag is not None:
        raw['velocity']['course_lag_s'] = course_lag
        raw['velocity']['speed_bias'] = [[1.0, -0.1]]
    turn = 0.0 if course_lag is None else 0.03      # north m/s gained per second
    path = tmp_path / 'velocity.yaml'
    path.write_text(yaml.safe_dump(raw))
    ns = unique_ns()
    node = start(ns, f'profile:={path}', DATUM_ARG, f'seed:={SEED}', 'max_pose_age:=3.0')
    pose_pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    vels = peer.collect(TwistWithCovarianceStamped, f'{ns}/vel')
    peer.wait_connected(pose_pub, f'{ns}/fix', node)
    assert peer.spin_until(lambda: peer.node.count_publishers(f'{ns}/vel') > 0, 10)
    drive(peer, pose_pub, fixes, STEPS,
          position=lambda k: (SPEED * (k - T0), turn * (k - T0) ** 2 / 2))
    peer.spin_for(0.5)
    rc, out = node.stop()
    assert rc == 0, out
    velocity = load_profile_file(path).velocity
    assert velocity.course_lag_s == course_lag
    w = velocity.errors(np.array([agent_key(SEED, '')], dtype=np.uint64), STEPS, T0)[:, 0]
    if table is not None:           # this agent's scale: not the section's
        one = velocity_from_dict({k: v for k, v in raw['velocity'].items()
                                  if k not in ('scale_sd_log', 'burst_share', 'burst_ratio')})
        w_one = one.errors(np.array([agent_key(SEED, '')], dtype=np.uint64), STEPS, T0)[:, 0]
        assert abs(np.log(np.std(w) / np.std(w_one))) > 0.05
    stamps = [stamp_ns(v.header.stamp) // NS for v in vels]
    # the chord centred at t - 0.4 s ends at t (never later): from the second step
    # on the truth covers it, and every fix then has a vel (with a course 1 s late,
    # from the third: its chord starts at t - 1.5 s)
    first = 1 if course_lag is None else 2
    assert stamps == list(range(T0 + first, T0 + STEPS)), stamps
    got = np.array([[v.twist.twist.linear.x, v.twist.twist.linear.y] for v in vels])
    if course_lag is None:
        expected = np.array([SPEED, 0.0]) + w[1:] * sd / 0.15
        # the chord is measured on the ellipsoid, the walk 23 m below it (the datum's
        # height): 1.4 m/s comes out 3.6 ppm longer, 5 micrometres per second
        np.testing.assert_allclose(got, expected, atol=2e-5)
    cov = np.array(vels[0].twist.covariance).reshape(6, 6)
    if course_lag is not None:      # about the truth: the speed bias's mean m adds m m^T
        k = stamps[0] - T0 - 1.0    # the course's chord, centred a second back
        heading = np.array([SPEED, turn * k]) / np.hypot(SPEED, turn * k)
        np.testing.assert_allclose(cov[:2, :2] - sd ** 2 * np.eye(2),
                                   0.01 * np.outer(heading, heading), atol=1e-8)
        cov[:2, :2] = np.diag([sd ** 2] * 2)
    # (the table is read at the chord's speed, 3.6 ppm above 1.4 m/s)
    assert np.diag(cov)[:3] == pytest.approx([sd ** 2] * 3, rel=1e-4) and np.diag(cov)[3] == 1e6
    assert not cov[:2, :2][~np.eye(2, dtype=bool)].any()
    # gps_error simulate reports the same speed and course for the same walk
    from gps_error_ros.model.geodesy import LocalTangentFrame
    from gps_error_ros.sim.velocity_sim import speed_and_course
    from ros_harness import DATUM
    t = np.arange(T0, T0 + STEPS, dtype=float)
    north = turn * (t - T0) ** 2 / 2
    lat, lon, _ = LocalTangentFrame(*DATUM).to_geodetic(SPEED * (t - T0), north, 0.0 * t)
    walk = {'t': t, 'agent': [''] * STEPS, 'truth_lat': np.asarray(lat),
            'truth_lon': np.asarray(lon)}
    speed, course, _, _ = speed_and_course(velocity, SEED, walk, T0, 1.0)
    assert np.isnan(speed[:first]).all()  # nor does simulate report one before the node does
    np.testing.assert_allclose(speed[first:], np.hypot(got[:, 0], got[:, 1]), atol=2e-5)
    np.testing.assert_allclose(course[first:], np.degrees(np.arctan2(got[:, 0], got[:, 1])) % 360,
                               atol=1e-3)
    if course_lag is not None:          # the course is the truth's a second late, not 0.4 s
        one = velocity_from_dict(dict(raw['velocity'], course_lag_s=0.4))
        one_speed, one_lag = speed_and_course(one, SEED, walk, T0, 1.0)[:2]
        assert np.nanmin(np.abs(course[first:] - one_lag[first:])) > 0.2
        unbiased = velocity_from_dict({k: v for k, v in raw['velocity'].items()
                                       if k != 'speed_bias'})      # and 0.1 m/s slower
        fair = speed_and_course(unbiased, SEED, walk, T0, 1.0)[0]
        assert np.nanmax(np.abs(speed[first:] - fair[first:] + 0.1)) < 0.02

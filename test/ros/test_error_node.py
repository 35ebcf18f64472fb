"""The error node as a real process, over real ROS 2 topics and /clock."""

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.fit.yule_walker import yule_walker
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.model.streams import agent_key
from gps_error_ros.fit.autocorrelation import autocorrelation, bartlett_acf_se, variance_se
from ros_harness import (DATUM, DATUM_ARG, drive, errors, NS, pose_msg,
                         stamp, stamp_ns, start, T0, unique_ns)

pytestmark = pytest.mark.integration


def test_one_fix_per_second_covariance_and_header(peer):
    ns = unique_ns()
    node = start(ns, 'profile:=DS5', DATUM_ARG, 'seed:=3')
    pose_pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pose_pub, f'{ns}/fix', node)
    drive(peer, pose_pub, fixes, 30)
    peer.spin_for(0.3)
    rc, out = node.stop()
    assert rc == 0, out
    stamps = [stamp_ns(f.header.stamp) for f in fixes]
    assert stamps == [k * NS for k in range(T0, T0 + 30)]
    # about the truth: the stationary covariance plus the mean's m m^T (DS5: 3.5, -1.0 m)
    model = load_profile('DS5').model()
    m = model.mean
    cov = model.stationary_cov + np.outer(m, m)
    expected = [cov[1, 1], cov[1, 0], 0.0, cov[0, 1], cov[0, 0], 0.0,
                0.0, 0.0, (2 * np.sqrt(np.diag(cov)).max()) ** 2]
    assert m[0] == pytest.approx(3.5, abs=0.1) and m[1] == pytest.approx(-1.0, abs=0.1)
    for f in fixes:
        assert list(f.position_covariance) == pytest.approx(expected, rel=1e-12)
        assert f.position_covariance_type == NavSatFix.COVARIANCE_TYPE_KNOWN
        assert f.status.status == NavSatStatus.STATUS_FIX
        assert f.status.service == NavSatStatus.SERVICE_GPS
        assert f.header.frame_id == 'gps'
        assert f.altitude == pytest.approx(DATUM[2], abs=1e-6)
        assert np.isfinite([f.latitude, f.longitude, f.altitude]).all()


def test_long_run_statistics_match_profile_theory(peer):
    """
    >= 10^4 steps: SD, lag-1 ACF and refitted innovation SD vs theory.

    Tolerances are 5 standard errors from the process's own long-run
    behaviour: Bartlett's formulas with the exact autocorrelation.
    """
    n_steps = 10000
    ns = unique_ns()
    # The clock runs up to 4 steps ahead of the truth's delivery here, so
    # the truth may be held up to 5 s (see README, max_pose_age).
    node = start(ns, 'profile:=DS1', DATUM_ARG, 'seed:=11', 'max_pose_age:=5.0')
    pose_pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pose_pub, f'{ns}/fix', node)
    drive(peer, pose_pub, fixes, n_steps, batch=4)
    rc, out = node.stop()
    assert rc == 0, out
    assert [stamp_ns(f.header.stamp) for f in fixes] == \
        [k * NS for k in range(T0, T0 + n_steps)]
    err = errors(fixes, DATUM[0], DATUM[1])
    profile = load_profile('DS1')
    model = profile.model()
    rho = model.autocorrelation(2000)
    var = np.diag(model.stationary_cov)
    for a, axis in enumerate(('north', 'east')):
        x = err[:, a]
        s2 = x.var()
        assert abs(s2 - var[a]) < 5 * variance_se(rho[:, a], n_steps, var[a]), \
            (axis, s2, var[a])
        r1 = autocorrelation(x, 1)[1]
        assert abs(r1 - rho[1, a]) < 5 * bartlett_acf_se(rho[:, a], 1, n_steps), \
            (axis, r1, rho[1, a])
        sigma_w = profile.axes[axis].sigma_w
        fit = yule_walker(x, 3)
        assert abs(fit.sigma_w - sigma_w) < 5 * sigma_w / np.sqrt(2 * n_steps), \
            (axis, fit.sigma_w, sigma_w)


def test_remap_params_file_and_p_override(peer, tmp_path):
    ns = unique_ns()
    params = tmp_path / 'params.yaml'
    params.write_text(
        '/**:\n  ros__parameters:\n    profile: ds2\n'
        f'    datum: [{DATUM[0]}, {DATUM[1]}, {DATUM[2]}]\n'
        '    seed: 5\n    frame_id: from_file\n')
    node = start(ns, extra=['--params-file', str(params),
                            '-p', 'frame_id:=phone_antenna',
                            '-r', 'pose:=truth/pose', '-r', 'fix:=noisy/fix'])
    pose_pub = peer.publisher(PoseStamped, f'{ns}/truth/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/noisy/fix')
    peer.wait_connected(pose_pub, f'{ns}/noisy/fix', node)
    drive(peer, pose_pub, fixes, 5)
    rc, out = node.stop()
    assert rc == 0, out
    assert len(fixes) == 5
    # -p given after --params-file wins (ROS 2: the later override wins)
    assert {f.header.frame_id for f in fixes} == {'phone_antenna'}
    sd = load_profile('DS2').model(about_truth=True).stationary_sd      # rms about the truth
    assert fixes[0].position_covariance[0] == pytest.approx(sd[1] ** 2)


def test_clock_jump_gives_one_fix_per_step_and_silence_without_truth(peer):
    ns = unique_ns()
    node = start(ns, 'profile:=DS7', DATUM_ARG, 'seed:=8')
    pose_pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pose_pub, f'{ns}/fix', node)
    for k in range(T0, T0 + 5):            # clock without any truth
        peer.set_clock(k * NS)
        peer.spin_for(0.05)
    peer.spin_for(0.5)
    assert fixes == []
    for k in range(T0 + 5, T0 + 16):        # truth for 11 steps, then one jump
        pose_pub.publish(pose_msg(k * NS))
    peer.spin_for(0.3)
    peer.set_clock((T0 + 15) * NS)
    assert peer.spin_until(lambda: len(fixes) >= 11, 5.0)
    peer.spin_for(0.5)
    rc, out = node.stop()
    assert rc == 0, out
    assert [stamp_ns(f.header.stamp) for f in fixes] == \
        [k * NS for k in range(T0 + 5, T0 + 16)]


def test_rate_two_hz_holds_the_one_hz_error(peer):
    ns = unique_ns()
    node = start(ns, 'profile:=DS2', DATUM_ARG, 'seed:=4', 'rate:=2.0')
    pose_pub = peer.publisher(PoseStamped, f'{ns}/pose')
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pose_pub, f'{ns}/fix', node)
    for h in range(2 * T0, 2 * T0 + 20):
        t = h * NS // 2
        pose_pub.publish(pose_msg(t))
        peer.set_clock(t)
        assert peer.spin_until(
            lambda: fixes and stamp_ns(fixes[-1].header.stamp) >= t, 5.0)
    rc, out = node.stop()
    assert rc == 0, out
    assert [stamp_ns(f.header.stamp) for f in fixes] == \
        [h * NS // 2 for h in range(2 * T0, 2 * T0 + 20)]
    err = errors(fixes, DATUM[0], DATUM[1]).reshape(10, 2, 2)
    np.testing.assert_allclose(err[:, 0], err[:, 1], atol=1e-6)
    assert np.all(np.abs(np.diff(err[:, 0, 0])) > 0)


@pytest.mark.parametrize('input_type', ['odometry', 'navsatfix'])
def test_other_input_types(peer, input_type):
    ns = unique_ns()
    frame = LocalTangentFrame(*DATUM)
    lat, lon, alt = frame.to_geodetic(120.0, -40.0, 2.0)
    params = [f'input_type:={input_type}', 'profile:=DS1', 'seed:=2']
    if input_type == 'odometry':
        params.append(DATUM_ARG)
        topic, msg_type = f'{ns}/odom', Odometry
    else:
        topic, msg_type = f'{ns}/fix_truth', NavSatFix
    node = start(ns, *params)
    pub = peer.publisher(msg_type, topic)
    fixes = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pub, f'{ns}/fix', node)
    for k in range(T0, T0 + 5):
        m = msg_type()
        m.header.stamp = stamp(k * NS)
        if input_type == 'odometry':
            m.pose.pose.position.x, m.pose.pose.position.y = 120.0, -40.0
            m.pose.pose.position.z = 2.0
            m.pose.pose.orientation.w = 1.0
        else:
            m.latitude, m.longitude, m.altitude = lat, lon, alt
        pub.publish(m)
        peer.set_clock(k * NS)
        assert peer.spin_until(
            lambda: fixes and stamp_ns(fixes[-1].header.stamp) >= k * NS, 5.0)
    rc, out = node.stop()
    assert rc == 0, out
    assert len(fixes) == 5
    err = errors(fixes, lat, lon)
    # the library's errors of DS1 for seed 2 at the fixes' own steps, as for pose input
    ref = load_profile('DS1').model().simulate(agent_key(2, ''), 5, start=T0)[:, 0]
    steps = [stamp_ns(f.header.stamp) // NS - T0 for f in fixes]
    np.testing.assert_allclose(err, ref[steps], atol=1e-4)
    assert fixes[0].altitude == pytest.approx(alt, abs=1e-6)


@pytest.mark.parametrize('params, name, hint', [
    (['profile:=DS3', DATUM_ARG], 'profile', 'DS5'),
    (['profile:=/nonexistent/p.yaml', DATUM_ARG], 'profile', 'not found'),
    (['profile:=DS5'], 'datum', 'required'),
    (['datum:=[91.0, 0.0, 0.0]'], 'datum', 'latitude'),
    (['datum:=[40.0]'], 'datum', 'lat_deg'),
    ([DATUM_ARG, 'rate:=0.0'], 'rate', '0.01'),
    ([DATUM_ARG, 'input_type:=gps'], 'input_type', 'navsatfix'),
    ([DATUM_ARG, 'seed:=abc'], 'seed', 'integer'),
    ([DATUM_ARG, 'frame_id:=""'], 'frame_id', 'non-empty'),
])
def test_bad_parameter_exits_non_zero_naming_it(params, name, hint):
    node = start(unique_ns(), *params)
    rc, out = node.wait_exit(timeout=20)
    assert rc != 0, out
    assert f"'{name}'" in out, out
    assert hint in out, out

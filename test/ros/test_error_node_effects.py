"""The error node with an extended profile, and with broken profile files."""

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.geodesy import difference, LocalTangentFrame
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.model.streams import agent_key
from ros_harness import (DATUM, DATUM_ARG, NodeProcess, NS, Peer, pose_msg, stamp_ns,
                         start, T0, unique_ns)

pytestmark = pytest.mark.integration

EXTENDED = """schema: 1
name: EXT
description: an extended test profile
source: test
rate_hz: 1.0
axes:
  north: {delta: 0.2, phi: [0.9, -0.1], sigma_w: 1.0}
  east:  {delta: -0.1, phi: [0.8], sigma_w: 0.7}
effects:
  cross_axis_coupling: {innovation_corr: 0.5}
  motion_lag: {lag_s: 2.0}
  heavy_tails: {dof: 5.0}
  variance_regimes: {scales: [1.0, 2.0], transition: [[0.9, 0.1], [0.2, 0.8]]}
"""


def test_extended_profile_errors_lag_and_full_covariance(tmp_path):
    """A walker at 1 m/s east: fix = truth(t - 2 s) + the library's errors."""
    f = tmp_path / 'ext.yaml'
    f.write_text(EXTENDED)
    ns = unique_ns()
    node = start(ns, f'profile:={f}', DATUM_ARG, 'seed:=21')
    peer = Peer()
    frame = LocalTangentFrame(*DATUM)
    try:
        pub = peer.publisher(PoseStamped, f'{ns}/pose')
        fixes = peer.collect(NavSatFix, f'{ns}/fix')
        peer.wait_connected(pub, f'{ns}/fix', node)
        for k in range(T0, T0 + 40):
            pub.publish(pose_msg(k * NS, east=1.0 * (k - T0)))
            peer.set_clock(k * NS)
            peer.spin_until(lambda: fixes and stamp_ns(fixes[-1].header.stamp)
                            >= (k - 1) * NS, 2.0)
        peer.spin_for(0.5)
        rc, out = node.stop()
        assert rc == 0, out
    finally:
        node.stop()
        peer.destroy()
    stamps = [stamp_ns(m.header.stamp) // NS for m in fixes]
    # no fix until the truth reaches 2 s back, then one per step
    assert stamps == list(range(T0 + 2, T0 + 39)) or \
        stamps == list(range(T0 + 2, T0 + 40)), stamps
    model = load_profile(str(f)).model()
    ref = model.simulate(np.array([agent_key(21, '')], dtype=np.uint64), 40,
                         start=T0)[:, 0]
    for m in fixes:
        k = stamp_ns(m.header.stamp) // NS
        lat, lon, _ = frame.to_geodetic(1.0 * (k - 2 - T0), 0.0, 0.0)
        n, e = difference(m.latitude, m.longitude, lat, lon)
        assert [float(n), float(e)] == pytest.approx(ref[k - T0], abs=1e-4), k
    cov = model.stationary_cov + np.outer(model.mean, model.mean)    # about the truth
    assert model.stationary_cov[0, 1] > 0
    for m in fixes:
        assert m.position_covariance_type == NavSatFix.COVARIANCE_TYPE_KNOWN
        c = list(m.position_covariance)
        assert c[:2] + c[3:5] == pytest.approx(
            [cov[1, 1], cov[0, 1], cov[0, 1], cov[0, 0]], rel=1e-12)


@pytest.mark.parametrize('text, hint', [
    ('schema: 1\nname: [unclosed\n', 'YAML'),
    (EXTENDED.replace('rate_hz: 1.0\n', ''), "'rate_hz' is missing"),
    (EXTENDED.replace('phi: [0.8]', 'phi: [1.2]'), 'axes.east'),
    (EXTENDED.replace('dof: 5.0', 'dof: 1.0'), 'effects.heavy_tails.dof'),
    (EXTENDED.replace('[0.2, 0.8]', '[0.5, 0.8]'),
     'effects.variance_regimes.transition[1]'),
])
def test_broken_profile_file_stops_the_node_naming_file_and_key(tmp_path, text, hint):
    f = tmp_path / 'broken.yaml'
    f.write_text(text)
    node = NodeProcess(['--ros-args', '-r', f'__ns:={unique_ns()}',
                        '-p', f'profile:={f}', '-p', DATUM_ARG])
    rc, out = node.wait_exit(timeout=20)
    assert rc == 2, out
    assert str(f) in out and hint in out, out


def test_unreadable_profile_stops_the_node_naming_it(tmp_path):
    d = tmp_path / 'a_directory.yaml'
    d.mkdir()                                  # exists, but cannot be read as a file
    node = NodeProcess(['--ros-args', '-r', f'__ns:={unique_ns()}',
                        '-p', f'profile:={d}', '-p', DATUM_ARG])
    rc, out = node.wait_exit(timeout=20)
    assert rc == 2, out
    assert str(d) in out and 'profile' in out, out

"""The CDR fast paths agree with rclpy's own (de)serialization."""

import math
import struct

from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.ros import cdr


@pytest.mark.parametrize('frame', ['', 'm', 'map', 'odom', 'a' * 7, 'world_frame_x'])
def test_pose_and_odometry(frame):
    p = PoseStamped()
    p.header.frame_id = frame
    p.header.stamp.sec, p.header.stamp.nanosec = 1_700_000_123, 456_789
    p.pose.position.x, p.pose.position.y, p.pose.position.z = 1.25, -3.5, math.pi
    p.pose.orientation.z, p.pose.orientation.w = 0.6, 0.8
    got = cdr.pose_stamped(serialize_message(p))
    assert got == (1_700_000_123_000_456_789, 1.25, -3.5, math.pi, 0.0, 0.0, 0.6, 0.8)
    for child in ('', 'base_link', 'b' * 5):
        o = Odometry()
        o.header = p.header
        o.child_frame_id = child
        o.pose.pose = p.pose
        assert cdr.odometry(serialize_message(o)) == got


@pytest.mark.parametrize('frame', ['', 'gps', 'gnss_link', 'x' * 12])
def test_navsatfix_read_and_template(frame):
    f = NavSatFix()
    f.header.frame_id = frame
    f.header.stamp.sec = 42
    f.status.status, f.status.service = NavSatStatus.STATUS_NO_FIX, 1
    f.latitude, f.longitude, f.altitude = 40.1, -73.2, 12.5
    assert cdr.navsatfix(serialize_message(f)) == (42 * 10 ** 9, -1, 40.1, -73.2, 12.5)
    cov = [float(i) for i in range(9)]
    tpl = cdr.FixTemplate(frame, cov, NavSatFix.COVARIANCE_TYPE_KNOWN,
                          NavSatStatus.STATUS_FIX, NavSatStatus.SERVICE_GPS)
    out = tpl.render(5_000_000_007, [1.5, -2.25], [3.0, 4.0], [5.0, 6.0])
    for raw, (lat, lon, alt) in zip(out, [(1.5, 3.0, 5.0), (-2.25, 4.0, 6.0)]):
        m = deserialize_message(raw, NavSatFix)
        assert (m.header.stamp.sec, m.header.stamp.nanosec) == (5, 7)
        assert m.header.frame_id == frame
        assert (m.latitude, m.longitude, m.altitude) == (lat, lon, alt)
        assert list(m.position_covariance) == cov
        assert m.position_covariance_type == NavSatFix.COVARIANCE_TYPE_KNOWN
        assert m.status.status == NavSatStatus.STATUS_FIX
        assert m.status.service == NavSatStatus.SERVICE_GPS


def _pose_big_endian(sec, nsec, frame, values):
    """Serialize a PoseStamped by hand in big-endian CDR (rclpy writes little)."""
    body = struct.pack('>iII', sec, nsec, len(frame) + 1) + frame.encode() + b'\0'
    body += bytes(-len(body) % 8)
    return b'\x00\x00\x00\x00' + body + struct.pack('>7d', *values)


def test_batch_parse_agrees_with_one_by_one():
    rng = np.random.default_rng(5)
    raws = []
    for i in range(60):
        frame = 'f' * int(rng.integers(0, 14))
        p = PoseStamped()
        p.header.frame_id = frame
        p.header.stamp.sec, p.header.stamp.nanosec = int(rng.integers(0, 2 ** 31)), 999_999_999
        p.pose.position.x, p.pose.position.y, p.pose.position.z = rng.normal(size=3)
        p.pose.orientation.w = 1.0
        o = Odometry()
        o.header = p.header
        o.child_frame_id = 'c' * int(rng.integers(0, 9))
        o.pose.pose = p.pose
        f = NavSatFix()
        f.header = p.header
        f.status.status = int(rng.integers(-1, 3))
        f.latitude, f.longitude, f.altitude = rng.normal(size=3)
        raws.append({'pose': serialize_message(p), 'odometry': serialize_message(o),
                     'navsatfix': serialize_message(f)})
    one = {'pose': cdr.pose_stamped, 'odometry': cdr.odometry, 'navsatfix': cdr.navsatfix}
    for kind in one:
        batch = [r[kind] for r in raws]
        # damaged messages: truncated at several places, empty, garbage length
        batch += [batch[0][:n] for n in (0, 3, 15, 17, len(batch[0]) - 1)]
        batch.append(batch[1][:12] + b'\xff\xff\xff\x7f' + batch[1][16:])
        if kind == 'pose':
            batch.append(_pose_big_endian(7, 8, 'map', range(7)))
        stamps, values, ok = cdr.parse_batch(kind, batch)
        for i, raw in enumerate(batch):
            try:
                want = one[kind](raw)
            except (struct.error, IndexError):
                assert not ok[i], (kind, i)
                continue
            assert ok[i], (kind, i)
            assert stamps[i] == want[0]
            assert tuple(values[i]) == want[1:]
        assert ok[:60].all() and not ok[60:64].any()
    assert cdr.parse_batch('pose', [])[0].shape == (0,)
    for kind in one:        # a batch of nothing but a short message
        assert not cdr.parse_batch(kind, [b''])[2].any()
        assert not cdr.parse_batch(kind, [b'\x00\x01\x00'])[2].any()


def test_frame_ids_are_read_from_the_bytes():
    frames = ['map', 'base_link', '', 'mapx', 'ma', 'map']
    raws = []
    for f in frames:
        p = PoseStamped()
        p.header.frame_id = f
        raws.append(serialize_message(p))
    raws.append(raws[0][:10])                                   # truncated
    assert cdr.frame_ids_are(raws, 'map').tolist() == [f == 'map' for f in frames] + [False]
    assert cdr.frame_ids_are(raws, '').tolist() == [f == '' for f in frames] + [False]
    assert [cdr.frame_id(r) for r in raws] == frames + ['']

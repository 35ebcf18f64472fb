"""Write real rosbag2 files (rosbags writer, CDR bytes from rclpy) for tests."""

from geometry_msgs.msg import PoseStamped
import numpy as np
from rclpy.serialization import serialize_message
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.traces import bag_io
from gps_error_ros.model.geodesy import LocalTangentFrame, offset

NS = 1_000_000_000


def _stamp(msg, t):
    ns = int(round(t * NS))
    msg.header.stamp.sec, msg.header.stamp.nanosec = ns // NS, ns % NS
    return ns


def write_walk_bag(path, storage, datum, err, fix_t, truth_rate=5.0,
                   truth='pose', speed=(0.8, 0.6), statuses=None):
    """
    Write /fix (truth + err at fix_t) and the truth stream to a bag.

    ``err`` is (n, 2) north/east metres at ``fix_t`` (s). The truth walks at
    constant ``speed`` (east, north m/s) from the datum.
    """
    frame = LocalTangentFrame(*datum)
    writer = bag_io.open_writer(path, storage)
    c_fix = bag_io.add_topic(writer, '/fix', 'sensor_msgs/msg/NavSatFix')
    ttype = {'pose': 'geometry_msgs/msg/PoseStamped',
             'navsatfix': 'sensor_msgs/msg/NavSatFix'}[truth]
    c_truth = bag_io.add_topic(writer, '/truth', ttype)
    t_truth = np.arange(fix_t[0] - 1.0, fix_t[-1] + 1.0, 1.0 / truth_rate)
    records = []
    for t in t_truth:
        e, n = speed[0] * t, speed[1] * t
        if truth == 'pose':
            m = PoseStamped()
            m.pose.position.x, m.pose.position.y = e, n
            m.pose.orientation.w = 1.0
        else:
            m = NavSatFix()
            lat, lon, alt = frame.to_geodetic(e, n, 0.0)
            m.latitude, m.longitude, m.altitude = lat, lon, alt
        records.append((_stamp(m, t), c_truth, m))
    e = speed[0] * np.asarray(fix_t)
    n = speed[1] * np.asarray(fix_t)
    tlat, tlon, _ = frame.to_geodetic(e, n, np.zeros_like(e))
    lat, lon = offset(tlat, tlon, err[:, 0], err[:, 1])
    for i, t in enumerate(fix_t):
        m = NavSatFix()
        m.status.status = NavSatStatus.STATUS_FIX if statuses is None else statuses[i]
        m.latitude, m.longitude = float(lat[i]), float(lon[i])
        records.append((_stamp(m, t), c_fix, m))
    records.sort(key=lambda r: r[0])
    for ns, conn, m in records:
        writer.write(conn, ns, serialize_message(m))
    writer.close()
    return t_truth

"""Conversions between ROS messages and the core's plain numbers."""

import math

from builtin_interfaces.msg import Time
from sensor_msgs.msg import NavSatFix, NavSatStatus

NS = 1_000_000_000


def stamp_ns(stamp):
    """Return a builtin_interfaces/Time as integer nanoseconds."""
    return stamp.sec * NS + stamp.nanosec


def to_stamp(ns):
    """Return integer nanoseconds as builtin_interfaces/Time."""
    return Time(sec=int(ns // NS), nanosec=int(ns % NS))


def _finite(*values):
    return all(math.isfinite(v) for v in values)


def pose_position(pose):
    """
    Return (east, north, up) of a geometry_msgs/Pose, or raise ValueError.

    The orientation is not used, but a non-finite or zero-length quaternion
    marks a corrupt message and is refused like a non-finite position.
    """
    p, q = pose.position, pose.orientation
    if not _finite(p.x, p.y, p.z):
        raise ValueError(f'non-finite position ({p.x}, {p.y}, {p.z})')
    norm = math.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w)
    if not math.isfinite(norm) or norm < 1e-9:
        raise ValueError(f'invalid quaternion ({q.x}, {q.y}, {q.z}, {q.w})')
    return p.x, p.y, p.z


def navsatfix_position(msg):
    """Return (lat, lon, alt) of a noise-free NavSatFix, or raise ValueError."""
    if msg.status.status == NavSatStatus.STATUS_NO_FIX:
        raise ValueError('status is STATUS_NO_FIX')
    if not _finite(msg.latitude, msg.longitude):
        raise ValueError(f'non-finite position ({msg.latitude}, {msg.longitude})')
    if abs(msg.latitude) > 90 or abs(msg.longitude) > 180:
        raise ValueError(f'latitude/longitude out of range '
                         f'({msg.latitude}, {msg.longitude})')
    alt = msg.altitude if math.isfinite(msg.altitude) else 0.0
    return msg.latitude, msg.longitude, alt


def enu_covariance(cov_ne, vertical_var):
    """
    Return the row-major ENU 3x3 covariance (9 floats) and its type.

    ``cov_ne`` is the 2x2 (north, east) horizontal covariance in m^2.
    """
    var_n, var_e, c = cov_ne[0][0], cov_ne[1][1], cov_ne[0][1]
    cov = [float(var_e), float(c), 0.0,
           float(c), float(var_n), 0.0,
           0.0, 0.0, float(vertical_var)]
    kind = NavSatFix.COVARIANCE_TYPE_KNOWN if c != 0.0 else \
        NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    return cov, kind


def make_fix(stamp, frame_id, lat, lon, alt, covariance, covariance_type):
    """Return a NavSatFix with a GPS fix at (lat, lon, alt)."""
    msg = NavSatFix()
    msg.header.stamp = to_stamp(stamp)
    msg.header.frame_id = frame_id
    msg.status.status = NavSatStatus.STATUS_FIX
    msg.status.service = NavSatStatus.SERVICE_GPS
    msg.latitude = float(lat)
    msg.longitude = float(lon)
    msg.altitude = float(alt)
    msg.position_covariance = covariance
    msg.position_covariance_type = covariance_type
    return msg

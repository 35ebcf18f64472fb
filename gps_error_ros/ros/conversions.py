"""Conversions between ROS messages and the core's plain numbers."""

from collections.abc import Sequence
import math
from typing import Any

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped, TwistWithCovarianceStamped
from nav_msgs.msg import Odometry
import numpy as np
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.model.state import FloatArray
from gps_error_ros.traces.validity import fix_problem, pose_problem

#: input_type -> (truth topic, message type): the one map both nodes use.
TRUTH_INPUTS = {
    'pose': ('pose', PoseStamped),
    'odometry': ('odom', Odometry),
    'navsatfix': ('fix_truth', NavSatFix),
}

NS = 1_000_000_000


def stamp_ns(stamp: Time) -> int:
    """Return a builtin_interfaces/Time as integer nanoseconds."""
    return stamp.sec * NS + stamp.nanosec


def to_stamp(ns: int) -> Time:
    """Return integer nanoseconds as builtin_interfaces/Time."""
    return Time(sec=int(ns // NS), nanosec=int(ns % NS))


def pose_position(pose: Any) -> tuple[float, float, float]:
    """
    Return (east, north, up) of a geometry_msgs/Pose, or raise ValueError.

    The rule is :func:`gps_error_ros.traces.validity.pose_problem`.
    """
    p, q = pose.position, pose.orientation
    problem = pose_problem((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
    if problem:
        raise ValueError(problem)
    return p.x, p.y, p.z


def navsatfix_position(msg: NavSatFix) -> tuple[float, float, float]:
    """Return (lat, lon, alt) of a noise-free NavSatFix, or raise ValueError."""
    problem = fix_problem(msg.status.status, msg.latitude, msg.longitude)
    if problem:
        raise ValueError(problem)
    alt = msg.altitude if math.isfinite(msg.altitude) else 0.0
    return msg.latitude, msg.longitude, alt


#: Off-diagonal (as a correlation) below which a covariance is diagonal: round-off.
DIAGONAL_TOLERANCE = 1e-9


def enu_covariance(cov_ne: FloatArray, vertical_var: float) -> tuple[list[float], int]:
    """
    Return the row-major ENU 3x3 covariance (9 floats) and its type.

    ``cov_ne`` is the 2x2 (north, east) horizontal covariance in m^2. An
    off-diagonal below :data:`DIAGONAL_TOLERANCE` of the diagonal's geometric
    mean is round-off (a correlation of 1e-9): it is written as 0 and the
    type is ``COVARIANCE_TYPE_DIAGONAL_KNOWN``.
    """
    cov = enu_covariances(np.asarray(cov_ne, dtype=float)[None], vertical_var)[0]
    if abs(cov[1]) <= DIAGONAL_TOLERANCE * math.sqrt(abs(cov[0] * cov[4])):
        cov[1] = cov[3] = 0.0
        kind = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    else:
        kind = NavSatFix.COVARIANCE_TYPE_KNOWN
    return [float(v) for v in cov], kind


def enu_covariances(cov_ne: FloatArray, vertical_var: float) -> FloatArray:
    """Return row-major ENU 3x3 covariances (m, 9) of north/east 2x2 ones (m, 2, 2)."""
    out = np.zeros((cov_ne.shape[0], 9))
    out[:, 0], out[:, 1] = cov_ne[:, 1, 1], cov_ne[:, 1, 0]
    out[:, 3], out[:, 4] = cov_ne[:, 0, 1], cov_ne[:, 0, 0]
    out[:, 8] = vertical_var
    return out


def make_fix(stamp: int, frame_id: str, lat: float, lon: float, alt: float,
             covariance: Sequence[float], covariance_type: int) -> NavSatFix:
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


def make_no_fix(stamp: int, frame_id: str) -> NavSatFix:
    """Return a NavSatFix saying "no fix": STATUS_NO_FIX, position NaN, covariance unknown."""
    msg = NavSatFix()
    msg.header.stamp = to_stamp(stamp)
    msg.header.frame_id = frame_id
    msg.status.status = NavSatStatus.STATUS_NO_FIX
    msg.status.service = NavSatStatus.SERVICE_GPS
    msg.latitude = msg.longitude = msg.altitude = math.nan
    msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_UNKNOWN
    return msg


#: Variance written for what a phone does not report (angular velocity): unknown.
UNKNOWN_VARIANCE = 1e6


def make_twist(stamp: int, frame_id: str, east: float, north: float, variance: float,
               mean: Sequence[float] | None = None) -> TwistWithCovarianceStamped:
    """
    Return a TwistWithCovarianceStamped: a phone's velocity in ENU (m/s).

    ``variance`` (m^2/s^2) on the linear x, y, z diagonal, plus ``mean mean^T``
    on x, y where the error has a ``mean`` (east, north m/s: the covariance
    about the truth); the angular part is not reported: zero, with a
    variance of :data:`UNKNOWN_VARIANCE`.
    """
    msg = TwistWithCovarianceStamped()
    msg.header.stamp = to_stamp(stamp)
    msg.header.frame_id = frame_id
    msg.twist.twist.linear.x = float(east)
    msg.twist.twist.linear.y = float(north)
    cov = [0.0] * 36
    for i in range(3):
        cov[7 * i] = float(variance)
        cov[7 * (i + 3)] = UNKNOWN_VARIANCE
    if mean is not None:
        for i in range(2):
            for j in range(2):
                cov[6 * i + j] += float(mean[i]) * float(mean[j])
    msg.twist.covariance = cov
    return msg


def make_pose(stamp: int, frame_id: str, east: float, north: float, up: float,
              covariance: Sequence[float]) -> PoseWithCovarianceStamped:
    """
    Return a fix as a PoseWithCovarianceStamped: its position in the map frame (ENU m).

    ``covariance``: the fix's row-major ENU 3x3 (9 floats, m^2), which fills the
    position block (x east, y north, z up); the orientation is not measured:
    identity, with a variance of :data:`UNKNOWN_VARIANCE` on each axis.
    """
    msg = PoseWithCovarianceStamped()
    msg.header.stamp = to_stamp(stamp)
    msg.header.frame_id = frame_id
    p = msg.pose.pose.position
    p.x, p.y, p.z = float(east), float(north), float(up)
    msg.pose.pose.orientation.w = 1.0
    cov = [0.0] * 36
    for i in range(3):
        for j in range(3):
            cov[6 * i + j] = float(covariance[3 * i + j])
        cov[7 * (i + 3)] = UNKNOWN_VARIANCE
    msg.pose.covariance = cov
    return msg

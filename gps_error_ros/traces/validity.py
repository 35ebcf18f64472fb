"""
When a fix or a truth sample is usable: the one rule, for every reader.

Used by the bag reader, the error node (truth) and the calibration node
(fixes), scalar or vectorised. ``STATUS_NO_FIX`` is the value of
``sensor_msgs/NavSatStatus.STATUS_NO_FIX``, declared here so that the core
needs no message package (the ROS layer's tests check that they agree).
"""

from typing import Any, Optional

import numpy as np

from gps_error_ros.model.state import Numbers

STATUS_NO_FIX = -1
#: Quaternions shorter than this mark a corrupt pose message.
MIN_QUATERNION_NORM = 1e-9


def fix_problem(status: int, lat: float, lon: float) -> Optional[str]:
    """Return why a fix (or a NavSatFix truth) is unusable, or None."""
    if status == STATUS_NO_FIX:
        return 'status is STATUS_NO_FIX'
    if not (np.isfinite(lat) and np.isfinite(lon)):
        return f'non-finite position ({lat}, {lon})'
    if abs(lat) > 90 or abs(lon) > 180:
        return f'latitude/longitude out of range ({lat}, {lon})'
    return None


def usable_fix(status: Numbers, lat: Numbers, lon: Numbers) -> Any:
    """Return True where a fix is usable (vectorised :func:`fix_problem`)."""
    status, lat, lon = (np.asarray(v) for v in (status, lat, lon))
    with np.errstate(invalid='ignore'):
        ok = (status != STATUS_NO_FIX) & np.isfinite(lat) & np.isfinite(lon) \
            & (np.abs(lat) <= 90) & (np.abs(lon) <= 180)
    return ok if ok.ndim else bool(ok)


def pose_problem(position: Numbers, orientation: Numbers) -> Optional[str]:
    """
    Return why a pose (x, y, z; quaternion x, y, z, w) is unusable, or None.

    The orientation is not used, but a non-finite or zero-length quaternion
    marks a corrupt message and is refused like a non-finite position.
    """
    if not np.all(np.isfinite(position)):
        return f'non-finite position {tuple(position)}'
    norm = float(np.sqrt(np.sum(np.square(orientation))))
    if not np.isfinite(norm) or norm < MIN_QUATERNION_NORM:
        return f'invalid quaternion {tuple(orientation)}'
    return None


def usable_pose(positions: Numbers, orientations: Numbers) -> Any:
    """Return True per row where a pose is usable (vectorised :func:`pose_problem`)."""
    positions, orientations = np.asarray(positions), np.asarray(orientations)
    with np.errstate(invalid='ignore', over='ignore'):
        qnorm = np.sqrt((orientations ** 2).sum(axis=-1))
        return np.isfinite(positions).all(axis=-1) & np.isfinite(qnorm) & \
            (qnorm >= MIN_QUATERNION_NORM)

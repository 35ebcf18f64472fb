"""
rosbag2 access through the ``rosbags`` library (no ROS installation needed).

``rosbags`` is imported when a bag is first opened, so that importing this
module (for :class:`BagError`, say) costs nothing for commands that read no
bag.
"""

from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path
from typing import Any, Iterator, Optional, Sequence

import numpy as np

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.traces.validity import pose_problem, STATUS_NO_FIX, usable_fix


@lru_cache(maxsize=1)
def typestore() -> Any:
    """Return the rosbags type store of ROS 2 Jazzy."""
    from rosbags.typesys import get_typestore, Stores
    return get_typestore(Stores.ROS2_JAZZY)


class BagError(ValueError):
    """A bag that cannot be read, or lacks what was asked for."""


@contextmanager
def opened(path: PathArg) -> Iterator[Any]:
    """Yield an open rosbags Reader; failures to open become BagError."""
    from rosbags.rosbag2 import Reader
    path = Path(path)
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # rosbags raises several unrelated types
        raise BagError(f'{path}: cannot open as a rosbag2: {exc}') from None
    try:
        yield reader
    finally:
        reader.close()


def read_messages(path: PathArg, topics: Sequence[str]) -> dict[str, list[tuple[int, Any]]]:
    """
    Return {topic: [(bag_timestamp_ns, message), ...]} for ``topics``.

    Messages are deserialised with the Jazzy type store. Raises
    :class:`BagError` naming the topics the bag has when one is missing.
    """
    path = Path(path)
    with opened(path) as reader:
        have = {c.topic: c.msgtype for c in reader.connections}
        missing = [t for t in topics if t not in have]
        if missing:
            listing = ', '.join(f'{t} ({m})' for t, m in sorted(have.items()))
            raise BagError(f'{path}: topic(s) {missing} not in the bag; it has: '
                           f'{listing or "no topics"}')
        out: dict[str, list[tuple[int, Any]]] = {t: [] for t in topics}
        conns = [c for c in reader.connections if c.topic in out]
        for conn, ts, raw in reader.messages(connections=conns):
            out[conn.topic].append(
                (ts, typestore().deserialize_cdr(raw, conn.msgtype)))
        return out


def open_writer(path: PathArg, storage: str = 'mcap') -> Any:
    """Return an opened rosbags :class:`Writer` (MCAP or SQLite3 storage)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    plugin = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}[storage]
    writer = Writer(Path(path), version=9, storage_plugin=plugin)
    writer.open()
    return writer


def add_topic(writer: Any, topic: str, msgtype: str) -> Any:
    """Add a connection for ``topic`` of ``msgtype`` (e.g. sensor_msgs/msg/NavSatFix)."""
    return writer.add_connection(topic, msgtype, typestore=typestore())


FIX_TYPE = 'sensor_msgs/msg/NavSatFix'
TRUTH_TYPES = {
    'geometry_msgs/msg/PoseStamped': 'pose',
    'nav_msgs/msg/Odometry': 'odometry',
    'sensor_msgs/msg/NavSatFix': 'navsatfix',
}
__all__ = ['BagError', 'FIX_TYPE', 'STATUS_NO_FIX', 'TRUTH_TYPES', 'add_topic',
           'message_count', 'open_writer', 'opened', 'read_fix_and_truth', 'read_messages',
           'topic_types', 'typestore']


def topic_types(path: PathArg) -> dict[str, str]:
    """Return {topic: msgtype} of a bag."""
    with opened(path) as reader:
        return {c.topic: c.msgtype for c in reader.connections}


def _stamp_s(header: Any) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def _truth_kind(path: PathArg, fix_topic: str, truth_topic: str, datum: Any) -> str:
    """Return the truth's kind ('pose', 'odometry', 'navsatfix'); check topics."""
    types = topic_types(path)
    listing = ', '.join(f'{t} ({m})' for t, m in sorted(types.items())) or \
        'no topics'
    for topic, allowed in ((fix_topic, (FIX_TYPE,)), (truth_topic, tuple(TRUTH_TYPES))):
        if topic not in types:
            raise BagError(f'{path}: topic {topic} not in the bag; it has: {listing}')
        if types[topic] not in allowed:
            raise BagError(f'{path}: topic {topic} has type {types[topic]}: '
                           f'expected {" or ".join(allowed)}')
    kind = TRUTH_TYPES[types[truth_topic]]
    if kind != 'navsatfix' and datum is None:
        raise BagError(f'{path}: truth topic {truth_topic} is a {kind} in a '
                       f'local frame: pass --datum LAT,LON[,ALT] of its origin')
    return kind


def _truth_sample(msg: Any, kind: str) -> Optional[tuple[float, float]]:
    """Return (x, y) of a truth message (lat/lon or ENU m), or None if unusable."""
    if kind == 'navsatfix':
        if not usable_fix(msg.status.status, msg.latitude, msg.longitude):
            return None
        return msg.latitude, msg.longitude
    pose = msg.pose if kind == 'pose' else msg.pose.pose
    p, q = pose.position, pose.orientation
    if pose_problem((p.x, p.y, p.z), (q.x, q.y, q.z, q.w)) is not None:
        return None
    return p.x, p.y


def read_fix_and_truth(path: PathArg, fix_topic: str, truth_topic: str, datum: Any = None,
                       progress: Any = None) -> tuple[dict[str, Any], dict[str, Any], int]:
    """
    Read measured fixes and ground truth from a bag.

    Parameters
    ----------
    path
        The rosbag2 directory or file (MCAP or SQLite3).
    fix_topic
        The fixes' topic (``sensor_msgs/NavSatFix``).
    truth_topic
        The truth's topic (PoseStamped, Odometry or NavSatFix).
    datum
        The map frame's origin, for pose or odometry truth (ENU metres).
    progress
        Called with each message's count, for a progress bar.

    Returns
    -------
    tuple
        ``(fixes, truth, skipped)``: ``fixes`` and ``truth`` are dicts of
        arrays ``t`` (header stamp, s), ``lat``, ``lon``; ``skipped`` counts
        the fixes left out by :mod:`~gps_error_ros.traces.validity`
        (``STATUS_NO_FIX``, non-finite or out of range). Truth samples that
        rule refuses are left out too.

    Raises
    ------
    BagError
        A missing topic or a wrong type (naming what the bag has), a missing
        datum for pose truth, or a bag that cannot be read.

    """
    kind = _truth_kind(path, fix_topic, truth_topic, datum)
    fixes: tuple[list[float], list[float], list[float]] = ([], [], [])
    truth: tuple[list[float], list[float], list[float]] = ([], [], [])
    skipped = 0
    try:
        with opened(path) as reader:
            conns = [c for c in reader.connections
                     if c.topic in (fix_topic, truth_topic)]
            for conn, _, raw in reader.messages(connections=conns):
                msg = typestore().deserialize_cdr(raw, conn.msgtype)
                if progress is not None:
                    progress.update()
                if conn.topic == fix_topic:
                    if not usable_fix(msg.status.status, msg.latitude, msg.longitude):
                        skipped += 1
                        continue
                    row, into = (msg.latitude, msg.longitude), fixes
                else:
                    sample = _truth_sample(msg, kind)
                    if sample is None:
                        continue
                    row, into = sample, truth
                into[0].append(_stamp_s(msg.header))
                into[1].append(row[0])
                into[2].append(row[1])
    except BagError:
        raise
    except Exception as exc:  # truncated or corrupt storage
        raise BagError(f'{path}: cannot read the bag (truncated or corrupt?): '
                       f'{type(exc).__name__}: {exc}') from None
    f = [np.asarray(v, dtype=float) for v in fixes]
    t, x, y = (np.asarray(v, dtype=float) for v in truth)
    if kind != 'navsatfix':
        x, y, _ = LocalTangentFrame(*datum).to_geodetic(x, y, np.zeros_like(x))
    return ({'t': f[0], 'lat': f[1], 'lon': f[2]},
            {'t': t, 'lat': np.asarray(x), 'lon': np.asarray(y)}, skipped)


def message_count(path: PathArg, topics: Sequence[str]) -> int:
    """Return how many messages of ``topics`` the bag holds."""
    with opened(path) as reader:
        return sum(c.msgcount for c in reader.connections if c.topic in topics)

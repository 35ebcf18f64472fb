"""rosbag2 access through the ``rosbags`` library (no ROS installation needed)."""

from contextlib import contextmanager
from pathlib import Path

import numpy as np

from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


class BagError(ValueError):
    """A bag that cannot be read, or lacks what was asked for."""


@contextmanager
def _opened(path):
    """Yield an open rosbags Reader; failures to open become BagError."""
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


def read_messages(path, topics):
    """
    Return {topic: [(bag_timestamp_ns, message), ...]} for ``topics``.

    Messages are deserialised with the Jazzy type store. Raises
    :class:`BagError` naming the topics the bag has when one is missing.
    """
    path = Path(path)
    with _opened(path) as reader:
        have = {c.topic: c.msgtype for c in reader.connections}
        missing = [t for t in topics if t not in have]
        if missing:
            listing = ', '.join(f'{t} ({m})' for t, m in sorted(have.items()))
            raise BagError(f'{path}: topic(s) {missing} not in the bag; it has: '
                           f'{listing or "no topics"}')
        out = {t: [] for t in topics}
        conns = [c for c in reader.connections if c.topic in out]
        for conn, ts, raw in reader.messages(connections=conns):
            out[conn.topic].append(
                (ts, TYPESTORE.deserialize_cdr(raw, conn.msgtype)))
        return out


def open_writer(path, storage='mcap'):
    """Return an opened rosbags :class:`Writer` (MCAP or SQLite3 storage)."""
    plugin = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}[storage]
    writer = Writer(Path(path), version=9, storage_plugin=plugin)
    writer.open()
    return writer


def add_topic(writer, topic, msgtype):
    """Add a connection for ``topic`` of ``msgtype`` (e.g. sensor_msgs/msg/NavSatFix)."""
    return writer.add_connection(topic, msgtype, typestore=TYPESTORE)


FIX_TYPE = 'sensor_msgs/msg/NavSatFix'
TRUTH_TYPES = {
    'geometry_msgs/msg/PoseStamped': 'pose',
    'nav_msgs/msg/Odometry': 'odometry',
    'sensor_msgs/msg/NavSatFix': 'navsatfix',
}
STATUS_NO_FIX = -1


def topic_types(path):
    """Return {topic: msgtype} of a bag."""
    with _opened(path) as reader:
        return {c.topic: c.msgtype for c in reader.connections}


def _stamp_s(header):
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def read_fix_and_truth(path, fix_topic, truth_topic, datum=None, progress=None):
    """
    Read measured fixes and ground truth from a bag.

    Returns ``(fixes, truth, skipped)``: ``fixes`` and ``truth`` are dicts of
    arrays ``t`` (header stamp, s), ``lat``, ``lon``; ``skipped`` counts the
    fixes left out for ``STATUS_NO_FIX`` or non-finite values. A pose or
    odometry truth (ENU metres) is converted with ``datum``.

    Raises
    ------
    BagError
        A missing topic or a wrong type (naming what the bag has), a missing
        datum for pose truth, or a bag that cannot be read.

    """
    import math

    from .geodesy import LocalTangentFrame

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
    fixes = {'t': [], 'lat': [], 'lon': []}
    truth = {'t': [], 'x': [], 'y': []}
    skipped = 0
    try:
        with _opened(path) as reader:
            conns = [c for c in reader.connections
                     if c.topic in (fix_topic, truth_topic)]
            for conn, _, raw in reader.messages(connections=conns):
                msg = TYPESTORE.deserialize_cdr(raw, conn.msgtype)
                if progress is not None:
                    progress.update()
                if conn.topic == fix_topic:
                    if msg.status.status == STATUS_NO_FIX or not (
                            math.isfinite(msg.latitude)
                            and math.isfinite(msg.longitude)):
                        skipped += 1
                        continue
                    fixes['t'].append(_stamp_s(msg.header))
                    fixes['lat'].append(msg.latitude)
                    fixes['lon'].append(msg.longitude)
                else:
                    if kind == 'navsatfix':
                        x, y = msg.latitude, msg.longitude
                    else:
                        pose = msg.pose if kind == 'pose' else msg.pose.pose
                        x, y = pose.position.x, pose.position.y
                    if not (math.isfinite(x) and math.isfinite(y)):
                        continue
                    truth['t'].append(_stamp_s(msg.header))
                    truth['x'].append(x)
                    truth['y'].append(y)
    except BagError:
        raise
    except Exception as exc:  # truncated or corrupt storage
        raise BagError(f'{path}: cannot read the bag (truncated or corrupt?): '
                       f'{type(exc).__name__}: {exc}') from None
    fixes = {k: np.asarray(v, dtype=float) for k, v in fixes.items()}
    tr = {k: np.asarray(v, dtype=float) for k, v in truth.items()}
    if kind == 'navsatfix':
        out_truth = {'t': tr['t'], 'lat': tr['x'], 'lon': tr['y']}
    else:
        frame = LocalTangentFrame(*datum)
        lat, lon, _ = frame.to_geodetic(tr['x'], tr['y'], np.zeros_like(tr['x']))
        out_truth = {'t': tr['t'], 'lat': np.asarray(lat), 'lon': np.asarray(lon)}
    return fixes, out_truth, skipped


def message_count(path, topics):
    """Return how many messages of ``topics`` the bag holds."""
    with _opened(path) as reader:
        return sum(c.msgcount for c in reader.connections if c.topic in topics)

"""rosbag2 access through the ``rosbags`` library (no ROS installation needed)."""

from pathlib import Path

from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


class BagError(ValueError):
    """A bag that cannot be read, or lacks what was asked for."""


def read_messages(path, topics):
    """
    Return {topic: [(bag_timestamp_ns, message), ...]} for ``topics``.

    Messages are deserialised with the Jazzy type store. Raises
    :class:`BagError` naming the topics the bag has when one is missing.
    """
    path = Path(path)
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # rosbags raises several unrelated types
        raise BagError(f'{path}: cannot open as a rosbag2: {exc}') from None
    try:
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
    finally:
        reader.close()


def open_writer(path, storage='mcap'):
    """Return an opened rosbags :class:`Writer` (MCAP or SQLite3 storage)."""
    plugin = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}[storage]
    writer = Writer(Path(path), version=9, storage_plugin=plugin)
    writer.open()
    return writer


def add_topic(writer, topic, msgtype):
    """Add a connection for ``topic`` of ``msgtype`` (e.g. sensor_msgs/msg/NavSatFix)."""
    return writer.add_connection(topic, msgtype, typestore=TYPESTORE)

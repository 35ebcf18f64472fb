"""
``gps_error_record``: record topics to a rosbag2 (``ros2 bag record``-like).

For installs without ros2cli (the PyPI wheels). Subscribes to each topic
with the QoS its publishers offer and writes the raw CDR bytes, stamped
with the receive time on the node's clock (``--use-sim-time``: the ROS
clock of ``/clock``; a message before the first tick takes that tick's
time), to an MCAP (or SQLite3) bag. Stops on Ctrl-C, on
SIGTERM or after ``--duration`` seconds, and closes the bag whole: every
message received is in it.
"""

import argparse
from collections.abc import Sequence
from pathlib import Path
import signal
import sys
import time
from typing import Any

import rclpy
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from gps_error_ros.ros.bag_play import message_class
from gps_error_ros.traces import bag_io

#: Seconds to wait for every topic's publisher to appear (its type comes from it).
DISCOVERY_S = 10.0


class Recorder:
    """The subscriptions and the bag they write to."""

    def __init__(self, node: Node, out: str, topics: Sequence[str], storage: str,
                 sim_time: bool = False) -> None:
        self.node = node
        self.sim_time = sim_time
        #: messages received before the first /clock (sim time): written with its time
        self._early: list[tuple[Any, bytes]] = []
        self.writer = bag_io.open_writer(out, storage)
        self.counts = {t: 0 for t in topics}
        self._subs: list[Any] = []
        for topic, msgtype, reliable in self._found(topics):
            conn = bag_io.add_topic(self.writer, topic, msgtype)
            qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE if reliable
                             else ReliabilityPolicy.BEST_EFFORT)
            cls = message_class(msgtype)
            self._subs.append(node.create_subscription(
                cls, topic, self._writer_for(topic, conn), qos, raw=True))

    def _found(self, topics: Sequence[str]) -> list[tuple[str, str, bool]]:
        """Return (topic, type, all publishers reliable) of each topic, once published."""
        deadline = time.monotonic() + DISCOVERY_S
        while True:
            types = dict(self.node.get_topic_names_and_types())
            missing = [t for t in topics if t not in types]
            if not missing:
                break
            if time.monotonic() > deadline:
                raise SystemExit(f'gps_error_record: no publisher of {", ".join(missing)} '
                                 f'within {DISCOVERY_S:g} s (is ROS_DOMAIN_ID the '
                                 f'publisher\'s? the topic spelled as it is?)')
            rclpy.spin_once(self.node, timeout_sec=0.1)
        out = []
        for t in topics:
            infos = self.node.get_publishers_info_by_topic(t)
            reliable = all(i.qos_profile.reliability == ReliabilityPolicy.RELIABLE
                           for i in infos)
            out.append((t, types[t][0], reliable))
        return out

    def _writer_for(self, topic: str, conn: Any) -> Any:
        """Return the callback that writes ``topic``'s raw messages."""
        def write(raw: bytes) -> None:
            now = self.node.get_clock().now().nanoseconds
            self.counts[topic] += 1
            if self.sim_time and now == 0:      # no /clock yet: stamp it with the first
                self._early.append((conn, raw))
                return
            self._flush(now)
            self.writer.write(conn, now, raw)
        return write

    def _flush(self, now: int) -> None:
        """Write the messages held for the first clock reading, stamped ``now``."""
        for conn, raw in self._early:
            self.writer.write(conn, now, raw)
        self._early.clear()

    def matched(self) -> bool:
        """Return whether every subscription is matched with a publisher."""
        return all(sub.get_publisher_count() > 0 for sub in self._subs)

    def close(self) -> None:
        """Close the bag (its index and metadata written); nothing received is left out."""
        if self._early:
            self.node.get_logger().warning(
                f'{len(self._early)} message(s) came before any /clock: stamped 0')
            self._flush(0)
        self.writer.close()


def record(out: str, topics: Sequence[str], duration_s: float | None = None,
           storage: str = 'mcap', use_sim_time: bool = False) -> dict[str, int]:
    """Record ``topics`` into the bag ``out`` until stopped; return the messages per topic."""
    params = [Parameter('use_sim_time', value=True)] if use_sim_time else []
    node = Node('gps_error_record', parameter_overrides=params)
    stop = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.append(True))
    recorder = Recorder(node, out, topics, storage, use_sim_time)
    # each subscription matched with its publishers before 'recording' is said
    deadline = time.monotonic() + DISCOVERY_S
    while not recorder.matched() and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    print(f'recording {", ".join(topics)} to {out}', flush=True)
    end = None if duration_s is None else time.monotonic() + duration_s
    try:
        while not stop and (end is None or time.monotonic() < end):
            rclpy.spin_once(node, timeout_sec=0.1)
    finally:
        recorder.close()
        node.destroy_node()
    return recorder.counts


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point."""
    p = argparse.ArgumentParser(prog='gps_error_record', description=__doc__.split('\n\n')[1])
    p.add_argument('out', help='the bag to write (a directory; it must not exist)')
    p.add_argument('topics', nargs='+', help='topics to record, e.g. /fix /pose')
    p.add_argument('--duration', type=float, default=None,
                   help='stop after this many wall-clock seconds (default: at Ctrl-C)')
    p.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap',
                   help='bag storage (default mcap)')
    p.add_argument('--use-sim-time', action='store_true',
                   help='stamp messages with the ROS clock of /clock, not wall time')
    args = p.parse_args(argv)
    if Path(args.out).exists():
        raise SystemExit(f'gps_error_record: {args.out} exists: give a directory that does '
                         f'not, so that no recording is overwritten')
    # the recorder handles SIGINT and SIGTERM itself, to close the bag whole
    rclpy.init(args=[], signal_handler_options=SignalHandlerOptions.NO)
    try:
        counts = record(args.out, args.topics, args.duration, args.storage,
                        args.use_sim_time)
    finally:
        rclpy.try_shutdown()
    print('recorded ' + ', '.join(f'{n} on {t}' for t, n in counts.items())
          + f'; wrote {args.out}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

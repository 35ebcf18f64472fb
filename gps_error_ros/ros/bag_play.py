"""
``gps_error_play``: replay a rosbag2 on its own clock (``ros2 bag play``-like).

For installs without ros2cli (the PyPI wheels). Publishes ``/clock`` from the
bag's timestamps and every message of the chosen topics as the raw CDR bytes
stored in the bag, ``--rate`` times faster than recorded. Messages go out
reliably, in bag order, each after the ``/clock`` tick of its timestamp.
"""

import argparse
from collections.abc import Collection, Sequence
import importlib
import sys
import time
from typing import Any

import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock

from gps_error_ros.model.atomic import PathArg
from gps_error_ros.ros.conversions import to_stamp
from gps_error_ros.traces.bag_io import opened


def message_class(msgtype: str) -> Any:
    """Return the rclpy class of ``pkg/msg/Name``."""
    pkg, kind, name = msgtype.split('/')
    return getattr(importlib.import_module(f'{pkg}.{kind}'), name)


def play(bag: PathArg, topics: Collection[str] | None = None, rate: float = 1.0,
         wait_for_subscribers: int = 0, node: Node | None = None) -> int:
    """Replay ``bag``; return the number of messages published."""
    own = node is None
    node = node or Node('gps_error_play')
    qos = QoSProfile(depth=1000)
    clock = node.create_publisher(Clock, '/clock', qos)
    with opened(bag) as reader:
        conns = [c for c in reader.connections if topics is None or c.topic in topics]
        pubs = {c.id: node.create_publisher(message_class(c.msgtype), c.topic, qos)
                for c in conns}
        deadline = time.monotonic() + 10.0
        while any(p.get_subscription_count() < wait_for_subscribers
                  for p in pubs.values()) and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        time.sleep(0.3)
        count, wall0, bag0 = 0, 0.0, 0
        first = True
        for conn, ts, raw in reader.messages(connections=conns):
            if first:
                first, wall0, bag0 = False, time.monotonic(), ts
            lag = (ts - bag0) / 1e9 / rate - (time.monotonic() - wall0)
            if lag > 0:
                time.sleep(lag)
            clock.publish(Clock(clock=to_stamp(ts)))
            pubs[conn.id].publish(raw)
            count += 1
    if own:
        node.destroy_node()
    return count


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point."""
    p = argparse.ArgumentParser(prog='gps_error_play', description=__doc__.split('\n\n')[1])
    p.add_argument('bag', help='rosbag2 directory (MCAP or SQLite3)')
    p.add_argument('--topics', nargs='*', default=None, help='topics to play (default all)')
    p.add_argument('--rate', type=float, default=1.0, help='speed factor (default 1)')
    p.add_argument('--wait-for-subscribers', type=int, default=0,
                   help='wait up to 10 s for this many subscribers per topic')
    args = p.parse_args(argv)
    rclpy.init()
    try:
        n = play(args.bag, args.topics, args.rate, args.wait_for_subscribers)
        print(f'played {n} messages')
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())

"""
The floor of the node benchmark: the same topics and messages, no model.

A bare rclpy process that does what the error node must do on the DDS side
and nothing else: per agent, one truth subscription (taken serialized, not
parsed) and one fix publisher (the node's QoS), and at each step of the ROS
clock one pre-serialized ``NavSatFix`` per agent with a truth message
(only the stamp's eight bytes are written per step). Its CPU is what the
node could not go below with rclpy and Fast DDS; ``bench_node.py``
runs it in place of the node and reports the node's CPU as a ratio to it.
Best-effort fixes go out as the node sends them (``send_paced``), in
bursts of ``FIX_BURST`` with ``FIX_BURST_PAUSE_S`` between (an unpaced burst of 1,000
overruns a subscriber's shared-memory queue, so a floor that did not pace
would lose fixes and do less work than the node it is the floor of).

At shutdown it prints a line in the node's summary format, so the
benchmark reads both the same way.
"""

import signal
import struct
import sys
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from geometry_msgs.msg import PoseStamped
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.ros.error_node import DrainedByTheNode, WaitsOnUndrained
from gps_error_ros.ros.fix_output import FIX_BURST, send_paced
from gps_error_ros.ros.lifecycle import QUICK_EXIT_PUBLISHERS, exit_at_once
from gps_error_ros.ros.topics import FIX_QOS, TRUTH_QOS

NS = 1_000_000_000


class FloorNode(WaitsOnUndrained, Node):
    """Subscriptions and publishers as the crowd node's, and a fixed fix."""

    def __init__(self, agents, reliability):
        super().__init__('gps_error_floor', parameter_overrides=[
            Parameter('use_sim_time', Parameter.Type.BOOL, True)])
        # drained by hand, as the node does: no executor waits on the truth topics
        self.drained = DrainedByTheNode()
        no_events_sub = SubscriptionEventCallbacks(use_default_callbacks=False)
        no_events_pub = PublisherEventCallbacks(use_default_callbacks=False)
        self.subs, self.pubs = [], []
        self.burst = FIX_BURST if reliability == 'best_effort' else None
        for name in agents:
            sub = self.create_subscription(PoseStamped, f'{name}/pose', lambda m: None,
                                           TRUTH_QOS['best_effort'], raw=True,
                                           event_callbacks=no_events_sub,
                                           callback_group=self.drained)
            self.subs.append((sub, sub.handle))
            self.pubs.append(self.create_publisher(
                NavSatFix, f'{name}/fix', FIX_QOS[reliability],
                event_callbacks=no_events_pub).handle)
        fix = NavSatFix()
        fix.header.frame_id = 'gps'
        fix.status.status = NavSatStatus.STATUS_FIX
        fix.status.service = NavSatStatus.SERVICE_GPS
        fix.latitude, fix.longitude = 40.75, -73.99
        fix.position_covariance = [4.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 64.0]
        fix.position_covariance_type = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
        raw = serialize_message(fix)
        self.head, self.tail = raw[:4], raw[12:]     # the stamp is bytes 4..12
        self.fixes = self.ticks = 0
        self.spent = self.worst = 0.0
        self.last_step = None
        self.create_timer(1.0, self._on_timer)

    def _on_timer(self):
        t0 = time.perf_counter()
        now = self.get_clock().now().nanoseconds
        if now <= 0:
            return
        step = now // NS
        got = set()
        for i, (sub, handle) in enumerate(self.subs):
            while handle.take_message(sub.msg_type, True) is not None:
                got.add(i)
        if step != self.last_step:
            self.last_step = step
            raw = self.head + struct.pack('<iI', step, 0) + self.tail
            order = sorted(got)
            send_paced([self.pubs[i] for i in order], [raw] * len(order), self.burst)
            self.fixes += len(got)
        dt = time.perf_counter() - t0
        self.ticks += 1
        self.spent += dt
        self.worst = max(self.worst, dt)

    def summary(self):
        """Return the run in the error node's summary format."""
        mean = 1e3 * self.spent / self.ticks if self.ticks else 0.0
        return (f'at shutdown: {self.ticks} timer ticks, {self.fixes} NavSatFix published '
                f'({self.fixes} with a position, 0 NO_FIX), 0 steps in an outage, 0 '
                f'non-finite fixes refused, 0 skipped without truth, 0 truth messages out '
                f'of order, 0 stamped in the future; wall time per tick {mean:.3f} ms mean, '
                f'{1e3 * self.worst:.3f} ms max')


def main(argv):
    """``floor_node.py N RELIABILITY [ROS args]``: serve a0 .. a{N-1}."""
    n, reliability = int(argv[1]), argv[2]
    rclpy.init(args=argv[3:])
    node = FloorNode([f'a{i}' for i in range(n)], reliability)
    print(f'floor node: serving {n} agents, {reliability} fixes', flush=True)
    signal.signal(signal.SIGTERM, lambda *a: rclpy.try_shutdown())
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    print(node.summary(), flush=True)
    if n > QUICK_EXIT_PUBLISHERS:       # as the error node: not minutes of teardown
        rclpy.try_shutdown()
        exit_at_once(0)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))

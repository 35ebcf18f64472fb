"""
``make demo``: a simulated Manhattan pedestrian through the error node.

A driver node publishes ``/clock`` and the walker's ground-truth pose on
``/pose``; the error node (a separate process, profile DS5, ``use_sim_time``)
publishes ``/fix``; the driver records both to a rosbag2 (MCAP). Simulated
time advances in lock step with the node (each second waits for that
second's fix), so the run is as fast as the node keeps up. Afterwards the bag
is read back, the errors are measured against the recorded truth, and a PNG
figure and a summary are written.
"""

import argparse
from collections.abc import Mapping, Sequence
import os
from pathlib import Path
import random
import shutil
import signal
import subprocess
import sys
import time
from typing import Any

import numpy as np

from gps_error_ros.sim.walker import Walk


def _ros_env() -> None:
    """Keep DDS on loopback, in a per-run domain unless one is given."""
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 100)))


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """Return the demo's command-line options."""
    p = argparse.ArgumentParser(
        prog='gps_error_demo',
        description='Walk a simulated pedestrian through Manhattan, run the '
                    'error node on it, record a rosbag2 and plot the errors.')
    p.add_argument('--out', default='demo_output', help='output directory')
    p.add_argument('--hours', type=float, default=2.0,
                   help='simulated hours to walk (default 2)')
    p.add_argument('--profile', default='DS5', help='error profile (default DS5)')
    p.add_argument('--seed', type=int, default=7, help='seed of walk and errors')
    p.add_argument('--pose-rate', type=int, default=5,
                   help='truth poses per simulated second (default 5)')
    return p.parse_args(argv)


class _Driver:
    """The demo's ROS side: the error node's process, /clock, poses, the bag."""

    def __init__(self, args: argparse.Namespace, bag_path: Path) -> None:
        import rclpy
        from geometry_msgs.msg import PoseStamped
        from rclpy.node import Node
        from rclpy.qos import QoSProfile
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import NavSatFix

        from gps_error_ros.sim.walker import MANHATTAN_DATUM
        from gps_error_ros.traces import bag_io

        self.rclpy, self.Clock = rclpy, Clock
        datum = '[%r, %r, %r]' % MANHATTAN_DATUM
        self.node_proc = subprocess.Popen(
            [sys.executable, '-m', 'gps_error_ros.ros.error_node',
             '--ros-args', '-p', 'use_sim_time:=true',
             '-p', f'profile:={args.profile}', '-p', f'datum:={datum}',
             '-p', f'seed:={args.seed}', '--log-level', 'warn'])
        rclpy.init()
        self.node = Node('demo_driver')
        reliable = QoSProfile(depth=100)
        self.clock_pub = self.node.create_publisher(Clock, '/clock', reliable)
        self.pose_pub = self.node.create_publisher(PoseStamped, '/pose', reliable)
        self.writer = bag_io.open_writer(bag_path, 'mcap')
        self.c_pose = bag_io.add_topic(self.writer, '/pose',
                                       'geometry_msgs/msg/PoseStamped')
        self.c_fix = bag_io.add_topic(self.writer, '/fix', 'sensor_msgs/msg/NavSatFix')
        self.last, self.count = -1, 0
        self.node_rc: int | str | None = None
        self.node.create_subscription(NavSatFix, '/fix', self._on_fix, reliable,
                                      raw=True)

    def _on_fix(self, raw: bytes) -> None:
        from rclpy.serialization import deserialize_message
        from sensor_msgs.msg import NavSatFix
        msg = deserialize_message(raw, NavSatFix)
        ns = msg.header.stamp.sec * 10 ** 9 + msg.header.stamp.nanosec
        self.writer.write(self.c_fix, ns, raw)
        self.last = max(self.last, ns)
        self.count += 1

    def wait_for_node(self, timeout: float = 30.0) -> None:
        """Wait until the error node subscribes to /pose and publishes /fix."""
        deadline = time.monotonic() + timeout
        while (self.pose_pub.get_subscription_count() == 0
               or self.node.count_publishers('/fix') == 0):
            if self.node_proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError('the error node did not come up '
                                   f'(exit code {self.node_proc.poll()})')
            self.rclpy.spin_once(self.node, timeout_sec=0.1)
        time.sleep(0.5)

    def walk(self, walk: Walk, t0: int, duration: int, pose_rate: int, wall0: float) -> int:
        """Publish poses and /clock for every step; return steps with no fix."""
        from geometry_msgs.msg import PoseStamped
        from rclpy.serialization import serialize_message

        from gps_error_ros.ros.conversions import to_stamp
        msg = PoseStamped()
        msg.header.frame_id = 'map'
        msg.pose.orientation.w = 1.0
        missed = 0
        for sec in range(duration + 1):
            for j in range(pose_rate):
                ns = t0 + sec * 10 ** 9 + j * 10 ** 9 // pose_rate
                e, n = walk.position((ns - t0) / 1e9)
                msg.header.stamp = to_stamp(ns)
                msg.pose.position.x, msg.pose.position.y = float(e), float(n)
                self.pose_pub.publish(msg)
                self.writer.write(self.c_pose, ns, serialize_message(msg))
                self.clock_pub.publish(self.Clock(clock=to_stamp(ns)))
                if j == 0:
                    missed += not self._wait_for_fix(ns, 2.0)
            if sec % 1800 == 0 and sec:
                print(f'demo: {sec / 3600:.1f} h simulated, {self.count} fixes, '
                      f'{time.monotonic() - wall0:.0f} s wall', flush=True)
        self._wait_for_fix(None, 1.0)
        return missed

    def _wait_for_fix(self, ns: int | None, timeout: float) -> bool:
        end = time.monotonic() + timeout
        while (ns is None or self.last < ns) and time.monotonic() < end:
            self.rclpy.spin_once(self.node, timeout_sec=0.01)
        return ns is not None and self.last >= ns

    def close(self) -> None:
        """Close the bag, stop ROS and the node (SIGINT, then kill)."""
        self.writer.close()
        self.node.destroy_node()
        self.rclpy.try_shutdown()
        if self.node_proc.poll() is None:
            self.node_proc.send_signal(signal.SIGINT)
        try:
            self.node_rc = self.node_proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            self.node_proc.kill()
            self.node_rc = 'killed'


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Run the demo; return the summary dict."""
    _ros_env()
    from gps_error_ros.model.profiles import load_profile
    from gps_error_ros.reports import demo_report
    from gps_error_ros.reports.jsonfile import write_json
    from gps_error_ros.sim.walker import MANHATTAN_DATUM, manhattan_walk

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    bag_path = out / 'demo_bag'
    if bag_path.exists():
        shutil.rmtree(bag_path)
    model = load_profile(args.profile).model()
    duration = int(round(args.hours * 3600))
    walk = manhattan_walk(duration + 5, np.random.default_rng(args.seed))
    driver = _Driver(args, bag_path)
    wall0 = time.monotonic()
    try:
        driver.wait_for_node()
        print(f'demo: walking {args.hours:g} simulated hours '
              f'({walk.t.size} route points), profile {args.profile}, datum '
              f'{list(MANHATTAN_DATUM)} (lat, lon, alt), '
              f'ROS_DOMAIN_ID={os.environ["ROS_DOMAIN_ID"]}', flush=True)
        missed = driver.walk(walk, 100 * 10 ** 9, duration, args.pose_rate, wall0)
    finally:
        wall = time.monotonic() - wall0
        driver.close()
    err = demo_report.errors_from_bag(bag_path, MANHATTAN_DATUM)
    summary = demo_report.summarise(err, model)
    summary.update({
        'profile': args.profile, 'datum': list(MANHATTAN_DATUM),
        'simulated_seconds': duration, 'wall_seconds': round(wall, 1),
        'speed_up': round(duration / wall, 1) if wall > 0 else None,
        'fixes_expected': duration + 1, 'steps_without_fix': int(missed),
        'node_exit_code': driver.node_rc,
        'bag': str(bag_path), 'figure': str(out / 'demo.png'),
    })
    demo_report.demo_figure(
        err, model, out / 'demo.png',
        f'gps_error_node, profile {args.profile}: '
        f'{duration / 3600:g} simulated hours of a Manhattan walk')
    write_json(out / 'summary.json', summary)
    return summary


def print_summary(s: Mapping[str, Any]) -> None:
    """Print the demo summary for a person."""
    print(f'\nfixes received: {s["fixes"]} of {s["fixes_expected"]} steps '
          f'({s["simulated_seconds"] / 3600:g} h simulated in '
          f'{s["wall_seconds"]} s wall, x{s["speed_up"]} real time)')
    print(f'{"axis":6} {"mean":>7} {"model":>7} {"sd":>7} {"model":>7} '
          f'{"rms":>7} {"lag-1 acf":>10} {"model":>7}')
    for a in ('north', 'east'):
        d = s[a]
        print(f'{a:6} {d["mean_m"]:7.2f} {d["theory_mean_m"]:7.2f} '
              f'{d["sd_m"]:7.2f} {d["theory_sd_m"]:7.2f} {d["rms_m"]:7.2f} '
              f'{d["lag1_acf"]:10.4f} {d["theory_lag1_acf"]:7.4f}')
    print('(metres; model = the profile\'s stationary mean / sd / acf; a '
          'single run of a process this persistent scatters around them)')
    print(f'bag: {s["bag"]}\nfigure: {s["figure"]}\n'
          f'summary: {Path(s["figure"]).with_name("summary.json")}')


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo from the command line."""
    args = parse_args(sys.argv[1:] if argv is None else argv)
    summary = run(args)
    print_summary(summary)
    ok = summary['node_exit_code'] == 0 and summary['fixes'] > 0
    return 0 if ok else 1


if __name__ == '__main__':
    raise SystemExit(main())

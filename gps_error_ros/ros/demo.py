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
import os
from pathlib import Path
import random
import shutil
import signal
import subprocess
import sys
import time

import numpy as np


def _ros_env():
    """Keep DDS on loopback, in a per-run domain unless one is given."""
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 100)))


def parse_args(argv):
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


def run(args):
    """Run the demo; return the summary dict."""
    _ros_env()
    import rclpy
    from geometry_msgs.msg import PoseStamped
    from rclpy.node import Node
    from rclpy.qos import QoSProfile
    from rclpy.serialization import deserialize_message, serialize_message
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import NavSatFix

    from .. import bag_io, report
    from ..profiles import load_profile
    from ..walker import MANHATTAN_DATUM, manhattan_walk
    from .conversions import to_stamp

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    bag_path = out / 'demo_bag'
    if bag_path.exists():
        shutil.rmtree(bag_path)
    model = load_profile(args.profile).model()
    duration = int(round(args.hours * 3600))
    walk = manhattan_walk(duration + 5, np.random.default_rng(args.seed))
    t0 = 100 * 10 ** 9            # simulated time starts at 100 s
    datum = '[%r, %r, %r]' % MANHATTAN_DATUM

    node_cmd = [sys.executable, '-m', 'gps_error_ros.ros.error_node',
                '--ros-args', '-p', 'use_sim_time:=true',
                '-p', f'profile:={args.profile}', '-p', f'datum:={datum}',
                '-p', f'seed:={args.seed}', '--log-level', 'warn']
    node_proc = subprocess.Popen(node_cmd)
    rclpy.init()
    driver = Node('demo_driver')
    reliable = QoSProfile(depth=100)
    clock_pub = driver.create_publisher(Clock, '/clock', reliable)
    pose_pub = driver.create_publisher(PoseStamped, '/pose', reliable)
    writer = bag_io.open_writer(bag_path, 'mcap')
    c_pose = bag_io.add_topic(writer, '/pose', 'geometry_msgs/msg/PoseStamped')
    c_fix = bag_io.add_topic(writer, '/fix', 'sensor_msgs/msg/NavSatFix')
    received = {'last': -1, 'count': 0}

    def on_fix(raw):
        msg = deserialize_message(raw, NavSatFix)
        ns = msg.header.stamp.sec * 10 ** 9 + msg.header.stamp.nanosec
        writer.write(c_fix, ns, raw)
        received['last'] = max(received['last'], ns)
        received['count'] += 1

    driver.create_subscription(NavSatFix, '/fix', on_fix, reliable, raw=True)
    wall0 = time.monotonic()
    missed = 0
    try:
        deadline = time.monotonic() + 30
        while (pose_pub.get_subscription_count() == 0
               or driver.count_publishers('/fix') == 0):
            if node_proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError('the error node did not come up '
                                   f'(exit code {node_proc.poll()})')
            rclpy.spin_once(driver, timeout_sec=0.1)
        time.sleep(0.5)
        msg = PoseStamped()
        msg.header.frame_id = 'map'
        msg.pose.orientation.w = 1.0
        sub = args.pose_rate
        print(f'demo: walking {args.hours:g} simulated hours '
              f'({walk.t.size} route points), profile {args.profile}, '
              f'ROS_DOMAIN_ID={os.environ["ROS_DOMAIN_ID"]}', flush=True)
        for sec in range(duration + 1):
            for j in range(sub):
                ns = t0 + sec * 10 ** 9 + j * 10 ** 9 // sub
                e, n = walk.position((ns - t0) / 1e9)
                msg.header.stamp = to_stamp(ns)
                msg.pose.position.x, msg.pose.position.y = float(e), float(n)
                raw = serialize_message(msg)
                pose_pub.publish(msg)
                writer.write(c_pose, ns, raw)
                clock_pub.publish(Clock(clock=to_stamp(ns)))
                if j == 0:
                    want = ns
                    wait_until = time.monotonic() + 2.0
                    while received['last'] < want and time.monotonic() < wait_until:
                        rclpy.spin_once(driver, timeout_sec=0.01)
                    missed += received['last'] < want
            if sec % 1800 == 0 and sec:
                print(f'demo: {sec / 3600:.1f} h simulated, '
                      f'{received["count"]} fixes, '
                      f'{time.monotonic() - wall0:.0f} s wall', flush=True)
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            rclpy.spin_once(driver, timeout_sec=0.05)
    finally:
        wall = time.monotonic() - wall0
        writer.close()
        driver.destroy_node()
        rclpy.try_shutdown()
        if node_proc.poll() is None:
            node_proc.send_signal(signal.SIGINT)
        try:
            node_rc = node_proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            node_proc.kill()
            node_rc = 'killed'

    err = report.errors_from_bag(bag_path, MANHATTAN_DATUM)
    summary = report.summarise(err, model)
    summary.update({
        'profile': args.profile, 'simulated_seconds': duration,
        'wall_seconds': round(wall, 1),
        'speed_up': round(duration / wall, 1) if wall > 0 else None,
        'fixes_expected': duration + 1, 'steps_without_fix': int(missed),
        'node_exit_code': node_rc,
        'bag': str(bag_path), 'figure': str(out / 'demo.png'),
    })
    report.demo_figure(err, model, out / 'demo.png',
                       f'gps_error_node, profile {args.profile}: '
                       f'{duration / 3600:g} simulated hours of a Manhattan walk')
    report.write_json(out / 'summary.json', summary)
    return summary


def print_summary(s):
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


def main(argv=None):
    """Run the demo from the command line."""
    args = parse_args(sys.argv[1:] if argv is None else argv)
    summary = run(args)
    print_summary(summary)
    ok = summary['node_exit_code'] == 0 and summary['fixes'] > 0
    return 0 if ok else 1


if __name__ == '__main__':
    raise SystemExit(main())

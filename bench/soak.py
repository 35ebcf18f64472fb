"""
Soak: a crowd node driven through many simulated hours on /clock.

The driver (this process) publishes one static pose per agent per simulated
second and then the clock tick, and waits for every agent's fix of the
previous step (drained from polled subscriptions) before going on: as fast
as the node keeps up, but at most ``--max-speed`` times real time. The cap
is the node's delivery contract, not a courtesy: its fix publishers are
reliable with a history of 100, and Fast DDS repairs a lost sample after a
heartbeat period (3 s), so a fix lost in transport can be repaired only while
fewer than 100 newer ones have been published on its topic, i.e. below about
33 steps per wall second. (Uncapped, the short soak ran at ~120x and once in
14 runs lost a whole step's burst for good.) Checked at the end, and
the run fails otherwise:

* every step produced exactly one fix per agent (keyed by agent and stamp,
  no duplicates, no gaps);
* the node's resident memory, sampled every ``--sample-s`` simulated seconds,
  stays flat: the last sample exceeds the first (taken after warm-up) by at
  most ``--rss-growth-mb``;
* the error statistics of the first and the last ``--window-s`` simulated
  seconds agree: per axis, the SDs differ by less than 5 standard errors of
  their difference (Bartlett, from the profile's exact autocorrelation), and
  so do the means.

Prints a summary line and exits non-zero on a failed check.
"""

import argparse
import json
import os
from pathlib import Path
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

NS = 1_000_000_000


def rss_mb(pid):
    with open(f'/proc/{pid}/status') as f:
        for line in f:
            if line.startswith('VmRSS'):
                return int(line.split()[1]) / 1024
    return float('nan')


def start_node(ns, params):
    """
    Start gps_error_node in namespace ``ns`` with the parameters file ``params``.

    Its output goes to ``<params>.log``, not to a pipe: nobody reads a pipe
    until the end, and a node that logs enough (agent_pattern logs each
    discovery round) fills the pipe's 64 kB and blocks in its next log call.
    """
    exe = Path(sys.executable).with_name('gps_error_node')
    log = open(Path(params).with_suffix('.log'), 'w+')
    node = subprocess.Popen([str(exe), '--ros-args', '-r', f'__ns:={ns}',
                             '--params-file', str(params)],
                            stdout=log, stderr=subprocess.STDOUT, text=True)
    node.log = log
    return node


def stop_node(node, timeout):
    """SIGINT the node (kill it after ``timeout`` s); return its output."""
    node.send_signal(signal.SIGINT)
    try:
        node.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        node.kill()
        node.wait()
    node.log.seek(0)
    out = node.log.read()
    node.log.close()
    return out


MAX_SPEED = 25.0     # simulated s per wall s: 75 fixes per topic per heartbeat period


def run(agents, sim_s, sample_s, window_s, rss_growth_mb, profile='DS2', seed=3,
        max_speed=MAX_SPEED):
    import rclpy
    from geometry_msgs.msg import PoseStamped
    from rclpy.node import Node
    from rclpy.qos import QoSProfile
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import NavSatFix

    from gps_error_ros.model.geodesy import difference
    from gps_error_ros.model.profiles import load_profile
    from gps_error_ros.ros.cdr import navsatfix
    from gps_error_ros.ros.conversions import to_stamp
    from gps_error_ros.fit.autocorrelation import variance_se

    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    lat0, lon0 = 40.75, -73.99
    ns = f'/soak{os.getpid()}'
    with tempfile.TemporaryDirectory() as work:
        params = Path(work, 'p.yaml')
        names = ', '.join(f'"a{i}"' for i in range(agents))
        params.write_text('/**:\n  ros__parameters:\n    use_sim_time: true\n'
                          f'    datum: [{lat0}, {lon0}, 0.0]\n    seed: {seed}\n'
                          f'    profile: {profile}\n    agents: [{names}]\n'
                          # the driver runs the clock one step ahead of the
                          # truth it waits on: see README, max_pose_age
                          '    max_pose_age: 3.0\n')
        node = start_node(ns, params)
        rclpy.init()
        drv = Node('soak_driver')
        try:
            qos = QoSProfile(depth=10)
            clock = drv.create_publisher(Clock, '/clock', qos)
            pubs = [drv.create_publisher(PoseStamped, f'{ns}/a{i}/pose', qos)
                    for i in range(agents)]
            subs = [drv.create_subscription(NavSatFix, f'{ns}/a{i}/fix', lambda m: None,
                                            QoSProfile(depth=100), raw=True)
                    for i in range(agents)]
            deadline = time.monotonic() + 60 + 0.1 * agents
            while any(p.get_subscription_count() == 0 for p in pubs) or \
                    any(s.handle.get_publisher_count() == 0 for s in subs):
                if time.monotonic() > deadline or node.poll() is not None:
                    raise RuntimeError('the node did not come up')
                time.sleep(0.1)
            time.sleep(1.0)
            seen = set()
            dup = 0
            err_start, err_end = [], []
            rss = []
            t0 = 1000
            msg = PoseStamped()
            msg.pose.orientation.w = 1.0
            wall0 = time.monotonic()
            last_step = t0 + sim_s - 1
            counted_n = 0

            def drain(want):
                nonlocal dup, counted_n
                got = 0
                for i, s in enumerate(subs):
                    while True:
                        taken = s.handle.take_message(s.msg_type, True)
                        if taken is None:
                            break
                        stamp, _, lat, lon, _ = navsatfix(taken[0])
                        sec = stamp // NS
                        key = (i, sec)
                        if key in seen:
                            dup += 1
                        elif sec < t0 + sim_s:
                            counted_n += 1
                        seen.add(key)
                        if sec - t0 < window_s:
                            err_start.append((i, lat, lon))
                        elif 0 <= last_step - sec < window_s:
                            err_end.append((i, lat, lon))
                        got += 1
                return got

            pending = 0
            # a few trailing steps (not counted) let the last counted steps
            # resolve: a pose drained after the final tick waits for the next
            tail = 5
            for k in range(t0, t0 + sim_s + tail):
                msg.header.stamp = to_stamp(k * NS)
                for i in range(agents):
                    msg.pose.position.x = 0.0
                    pubs[i].publish(msg)
                clock.publish(Clock(clock=to_stamp(k * NS)))
                pending += agents
                # wait for the previous step's fixes before going on
                end = time.monotonic() + 10
                while pending > agents and time.monotonic() < end:
                    pending -= drain(k)
                    if pending > agents:
                        time.sleep(0.0005)
                ahead = (k + 1 - t0) / max_speed - (time.monotonic() - wall0)
                if ahead > 0:
                    time.sleep(ahead)
                if (k - t0) % sample_s == 0 and t0 < k <= t0 + sim_s:
                    rss.append(rss_mb(node.pid))
            # every counted fix, also one repaired late by reliable QoS
            end = time.monotonic() + 30
            while counted_n < agents * sim_s and time.monotonic() < end:
                drain(t0 + sim_s)
                time.sleep(0.01)
            rss.append(rss_mb(node.pid))
            wall = time.monotonic() - wall0
        finally:
            drv.destroy_node()
            rclpy.try_shutdown()
            out = stop_node(node, timeout=120)
    expected = {(i, k) for i in range(agents) for k in range(t0, t0 + sim_s)}
    counted = {key for key in seen if key[1] < t0 + sim_s}
    missing_keys = expected - counted
    missing = len(missing_keys)
    extra = len(counted - expected)
    missing_steps = sorted({k - t0 for _, k in missing_keys})[:20]
    model = load_profile(profile).model()
    rho = model.autocorrelation(3000)
    var = np.diag(model.stationary_cov)
    stats_ok = True
    report = {}
    for label, rows in (('start', err_start), ('end', err_end)):
        a = np.array(rows)
        n, e = difference(a[:, 1], a[:, 2], lat0, lon0)
        report[label] = np.stack([n, e], axis=1)
    checks = {}
    for ax, name in enumerate(('north', 'east')):
        s0, s1 = report['start'][:, ax], report['end'][:, ax]
        # each window holds agents x window_s samples: agents independent series
        se_var = variance_se(rho[:, ax], window_s, var[ax]) / np.sqrt(agents)
        d_sd = np.sqrt(s1.var()) - np.sqrt(s0.var())
        se_sd = np.sqrt(2) * se_var / (2 * np.sqrt(var[ax]))
        se_mean = np.sqrt(2 * var[ax] * (1 + 2 * rho[1:, ax].sum()) / (window_s * agents))
        ok = abs(d_sd) < 5 * se_sd and abs(s1.mean() - s0.mean()) < 5 * se_mean
        stats_ok &= bool(ok)
        checks[name] = {'sd_start': float(s0.std()), 'sd_end': float(s1.std()),
                        'sd_theory': float(np.sqrt(var[ax])),
                        'mean_start': float(s0.mean()), 'mean_end': float(s1.mean()),
                        'ok': bool(ok)}
    growth = rss[-1] - rss[0] if len(rss) > 1 else 0.0
    result = {
        'agents': agents, 'simulated_s': sim_s, 'wall_s': wall,
        'speed_x_real_time': sim_s / wall, 'fixes_expected': len(expected),
        'fixes_received': len(counted & expected), 'missing': missing, 'unexpected': extra,
        'missing_steps': missing_steps, 'duplicates': dup,
        'rss_mb_samples': [round(r, 1) for r in rss],
        'rss_growth_mb': growth, 'stats': checks,
        'passed': missing == 0 and extra == 0 and dup == 0 and growth <= rss_growth_mb
        and stats_ok,
        'node_summary': [ln for ln in out.splitlines() if 'at shutdown' in ln],
    }
    return result


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--agents', type=int, default=100)
    p.add_argument('--hours', type=float, default=24.0, help='simulated hours')
    p.add_argument('--sample-s', type=int, default=3600)
    p.add_argument('--window-s', type=int, default=3600)
    p.add_argument('--rss-growth-mb', type=float, default=20.0)
    p.add_argument('--max-speed', type=float, default=MAX_SPEED,
                   help='at most this many simulated seconds per wall second (default '
                        f'{MAX_SPEED:g}: faster, a fix lost in transport may be gone from '
                        'the node\'s history of 100 before the 3 s repair)')
    p.add_argument('--json', help='write the result here')
    args = p.parse_args(argv)
    r = run(args.agents, int(args.hours * 3600), args.sample_s, args.window_s,
            args.rss_growth_mb, max_speed=args.max_speed)
    print(f'soak {r["agents"]} agents x {r["simulated_s"] / 3600:g} simulated h in '
          f'{r["wall_s"]:.0f} s (x{r["speed_x_real_time"]:.0f}): fixes '
          f'{r["fixes_received"]}/{r["fixes_expected"]}, missing {r["missing"]} '
          f'(at steps {r["missing_steps"]}), '
          f'duplicates {r["duplicates"]}; RSS {r["rss_mb_samples"][0]:.0f} -> '
          f'{r["rss_mb_samples"][-1]:.0f} MB (growth {r["rss_growth_mb"]:.1f} MB, '
          f'bound {args.rss_growth_mb}); error SD start/end north '
          f'{r["stats"]["north"]["sd_start"]:.2f}/{r["stats"]["north"]["sd_end"]:.2f}, '
          f'east {r["stats"]["east"]["sd_start"]:.2f}/{r["stats"]["east"]["sd_end"]:.2f} '
          f'(theory {r["stats"]["north"]["sd_theory"]:.2f}/'
          f'{r["stats"]["east"]["sd_theory"]:.2f}): '
          f'{"PASSED" if r["passed"] else "FAILED"}', flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(r, indent=1))
    return 0 if r['passed'] else 1


if __name__ == '__main__':
    raise SystemExit(main())

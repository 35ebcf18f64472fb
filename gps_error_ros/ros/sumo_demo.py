"""
``make demo-sumo``: SUMO's pedestrians get smartphone GPS errors, live.

Builds a small street grid with people walking (:mod:`sim.sumo_scenario`),
starts the error node with ``agent_pattern:=/peds/*/pose`` and then
``gps_error_sumo`` on the scenario; a recorder node in this process
subscribes to every person's truth and fixes as SUMO runs. Afterwards it
writes the fixes as a trace CSV (``t, agent, lat, lon, truth_lat,
truth_lon``, which ``gps_error calibrate`` reads), a figure (the grid, true
walks and noisy fixes; the errors over time) and a summary.
"""

import argparse
from collections.abc import Sequence
import csv
from functools import partial
import os
from pathlib import Path
import random
import signal
import subprocess
import sys
import time
from typing import Any, IO

from gps_error_ros.model.geodesy import LocalTangentFrame

NS = 1_000_000_000


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """Return the demo's command-line options."""
    p = argparse.ArgumentParser(
        prog='gps_error_sumo_demo',
        description='Run SUMO pedestrians through gps_error_sumo and the error node '
                    '(agent_pattern); record the fixes and plot them.')
    p.add_argument('--out', default='demo_sumo_output', help='output directory')
    p.add_argument('--profile', default='DS5', help='error profile (default DS5)')
    p.add_argument('--seed', type=int, default=7, help='seed of scenario and errors')
    p.add_argument('--depart-until', type=float, default=60.0,
                   help='people start walking until this SUMO time, s (default 60)')
    p.add_argument('--speed', type=float, default=20.0,
                   help='simulated seconds per wall second (default 20)')
    return p.parse_args(argv)


def _spawn(argv: Sequence[str], log: IO[Any]) -> subprocess.Popen[bytes]:
    exe = Path(sys.executable).with_name(argv[0])
    return subprocess.Popen([str(exe), *argv[1:]], stdout=log, stderr=subprocess.STDOUT)


class _Recorder:
    """Truth and fixes of every person, keyed (person, stamp ns)."""

    def __init__(self, persons: Sequence[str], frame: LocalTangentFrame) -> None:
        import rclpy
        from geometry_msgs.msg import PoseStamped
        from rclpy.node import Node
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import NavSatFix

        from gps_error_ros.ros.sumo_bridge import ros_name
        self.rclpy, self.frame = rclpy, frame
        self.node = Node('sumo_demo_recorder')
        self.truth: dict[tuple[str, int], Any] = {}
        self.fixes: dict[tuple[str, int], Any] = {}
        qos = QoSProfile(depth=1000)
        for p in persons:
            name = ros_name(p)
            self.node.create_subscription(PoseStamped, f'/peds/{name}/pose',
                                          partial(self._on_pose, p), qos)
            self.node.create_subscription(NavSatFix, f'/peds/{name}/fix',
                                          partial(self._on_fix, p), qos)

    def _on_pose(self, person: str, msg: Any) -> None:
        self._store(self.truth, person, msg.header.stamp, msg.pose.position)

    def _on_fix(self, person: str, msg: Any) -> None:
        self._store(self.fixes, person, msg.header.stamp, msg)

    def _store(self, box: dict[tuple[str, int], Any], person: str, stamp: Any,
               value: Any) -> None:
        box[(person, stamp.sec * NS + stamp.nanosec)] = value

    def wait_for_node(self, proc: subprocess.Popen[bytes], timeout: float = 30.0) -> None:
        """
        Wait until the error node is seen (its /diagnostics), then a second more.

        Discovery goes both ways at about the same time: once the recorder
        sees the node, the node knows the recorder's subscriptions, and the
        first fixes of the first person are not published before they match.
        """
        end = time.monotonic() + timeout
        while self.node.count_publishers('/diagnostics') == 0:
            if proc.poll() is not None or time.monotonic() > end:
                raise RuntimeError(f'the error node did not come up (exit code {proc.poll()})')
            self.rclpy.spin_once(self.node, timeout_sec=0.1)
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            self.rclpy.spin_once(self.node, timeout_sec=0.1)

    def spin_while(self, proc: subprocess.Popen[bytes], timeout: float) -> bool:
        """Record until ``proc`` exits (or ``timeout`` s); return whether it did."""
        end = time.monotonic() + timeout
        while proc.poll() is None and time.monotonic() < end:
            self.rclpy.spin_once(self.node, timeout_sec=0.05)
        settle = time.monotonic() + 2.0
        while time.monotonic() < settle:
            self.rclpy.spin_once(self.node, timeout_sec=0.05)
        return proc.poll() is not None

    def rows(self) -> list[tuple[float, str, float, float, float, float]]:
        """Return every fix with its truth (time, agent, both lat/lon), sorted."""
        out: list[tuple[float, str, float, float, float, float]] = []
        for (p, ns), fix in sorted(self.fixes.items()):
            pos = self.truth.get((p, ns))
            if pos is None:
                continue
            lat, lon, _ = self.frame.to_geodetic(pos.x, pos.y, pos.z)
            out.append((ns / NS, p, fix.latitude, fix.longitude, lat, lon))
        return out


def _write_trace(path: Path, rows: Sequence[Sequence[Any]]) -> None:
    with open(path, 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(['t', 'agent', 'lat', 'lon', 'truth_lat', 'truth_lon'])
        for t, p, lat, lon, tlat, tlon in rows:
            w.writerow([f'{t:.3f}', p, f'{lat:.9f}', f'{lon:.9f}', f'{tlat:.9f}',
                        f'{tlon:.9f}'])


def _stop(proc: subprocess.Popen[bytes]) -> int | str:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        return proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        return 'killed'


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Run the demo; return the summary dict."""
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 100)))
    import rclpy

    from gps_error_ros.reports import sumo_figure
    from gps_error_ros.reports.jsonfile import write_json
    from gps_error_ros.sim.sumo_scenario import Georeference
    from gps_error_ros.sim.sumo_scenario import build_grid_scenario

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    sc = build_grid_scenario(out / 'scenario', grid=4, length=80.0,
                             depart_until=args.depart_until, period=3.0, seed=args.seed)
    geo = Georeference(sc.net, None)
    datum = '[%r, %r, %r]' % geo.datum
    log = open(out / 'nodes.log', 'w')
    node = _spawn(['gps_error_node', '--ros-args', '-p', 'use_sim_time:=true',
                   '-p', f'profile:={args.profile}', '-p', f'datum:={datum}',
                   '-p', f'seed:={args.seed}', '-p', 'max_pose_age:=0.5',
                   '-p', 'input_reliability:=reliable',
                   '-p', f'start_time:={sc.begin!r}',
                   '-p', 'agent_pattern:=/peds/*/pose', '-p', 'agent_timeout:=5.0'], log)
    rclpy.init()
    rec = _Recorder(sc.persons, geo.frame)
    rec.wait_for_node(node)
    wall0 = time.monotonic()
    bridge = _spawn(['gps_error_sumo', '--ros-args', '-p', f'sumocfg:={sc.sumocfg}',
                     '-p', f'speed:={args.speed}', '-p', 'wait_for_clock:=1',
                     '-p', 'match_timeout:=10.0'], log)
    try:
        print(f'demo-sumo: {len(sc.persons)} people on a 4 x 4 grid at '
              f'{geo.datum[0]:.5f}, {geo.datum[1]:.5f}; SUMO at {args.speed:g}x, '
              f'ROS_DOMAIN_ID={os.environ["ROS_DOMAIN_ID"]}', flush=True)
        finished = rec.spin_while(bridge, timeout=1800)
    finally:
        wall = time.monotonic() - wall0
        bridge_rc, node_rc = _stop(bridge), _stop(node)
        rows = rec.rows()
        rec.node.destroy_node()
        rclpy.try_shutdown()
        log.close()
    _write_trace(out / 'fixes.csv', rows)
    sumo_figure.live_figure(sc.net, geo, rows, out / 'demo_sumo.png',
                            f'gps_error_sumo + gps_error_node (agent_pattern), '
                            f'profile {args.profile}')
    summary = {
        'people': len(sc.persons), 'people_with_fixes': len({r[1] for r in rows}),
        'truth_messages': len(rec.truth), 'fixes': len(rec.fixes),
        'person_steps_without_fix': len(set(rec.truth) - set(rec.fixes)),
        'without_fix_first': [[p, ns / NS] for p, ns in
                              sorted(set(rec.truth) - set(rec.fixes))[:20]],
        'sumo_finished': finished, 'bridge_exit_code': bridge_rc, 'node_exit_code': node_rc,
        'wall_seconds': round(wall, 1), 'datum': list(geo.datum),
        'trace': str(out / 'fixes.csv'), 'figure': str(out / 'demo_sumo.png'),
        'log': str(out / 'nodes.log'),
    }
    write_json(out / 'summary.json', summary)
    return summary


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo from the command line; 0 when every person-step got a fix."""
    s = run(parse_args(sys.argv[1:] if argv is None else argv))
    print(f'{s["people_with_fixes"]} of {s["people"]} people got fixes: {s["fixes"]} fixes '
          f'for {s["truth_messages"]} truth poses ({s["person_steps_without_fix"]} without '
          f'a fix) in {s["wall_seconds"]} s wall\ntrace: {s["trace"]}\nfigure: '
          f'{s["figure"]}\nnode logs: {s["log"]}')
    ok = (s['sumo_finished'] and s['bridge_exit_code'] == 0 and s['node_exit_code'] == 0
          and s['fixes'] > 0 and s['person_steps_without_fix'] == 0)
    return 0 if ok else 1


if __name__ == '__main__':
    raise SystemExit(main())

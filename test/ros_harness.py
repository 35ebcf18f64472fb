"""
Start the real nodes as processes and talk to them over real topics.

There is no launch_testing on PyPI: a subprocess per node and an rclpy test
node in the test process do the same job.
"""

import itertools
import os
from pathlib import Path
import shutil
import signal
import subprocess
import sys
import threading
import time

from geometry_msgs.msg import PoseStamped
import numpy as np
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock

from gps_error_ros.model.geodesy import difference

NS = 1_000_000_000
_counter = itertools.count()
_LIVE = []


def stop_all():
    """Kill every node process a test started and left running."""
    while _LIVE:
        proc = _LIVE.pop()
        if proc.proc.poll() is None:
            proc.proc.kill()
            proc.proc.communicate()


def node_executable(name='gps_error_node'):
    """Return the argv prefix that runs the installed console script."""
    exe = Path(sys.executable).with_name(name)
    if exe.exists():
        return [str(exe)]
    found = shutil.which(name)
    if found:
        return [found]
    raise FileNotFoundError(f'{name} is not installed next to {sys.executable}')


def unique_ns():
    """Return a fresh namespace so tests in one domain do not meet."""
    return f'/t{os.getpid()}_{next(_counter)}'


class NodeProcess:
    """A node running as a child process."""

    def __init__(self, args, name='gps_error_node', env=None):
        self.argv = node_executable(name) + list(args)
        # what wait_connected needs to know: the node's namespace, and whether
        # it runs on /clock
        self.namespace = next((a.split(':=', 1)[1] for a in args
                               if str(a).startswith('__ns:=')), None)
        self.sim_time = 'use_sim_time:=true' in args
        self.proc = subprocess.Popen(
            self.argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True, env=env)
        self._output = None
        _LIVE.append(self)

    def stop(self, timeout=10):
        """SIGINT the node; return (exit code, output)."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            out, _ = self.proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, _ = self.proc.communicate()
        self._output = (self._output or '') + (out or '')
        return self.proc.returncode, self._output

    def wait_output(self, *texts, timeout=20.0):
        """
        Read the node's output until a line holds one of ``texts``; return whether one did.

        What was read is kept for :meth:`stop`. On a timeout the reader
        thread reads on, and what it reads after is lost to :meth:`stop`.
        """
        lines, found = [], threading.Event()

        def read():
            for line in self.proc.stdout:
                lines.append(line)
                if any(t in line for t in texts):
                    found.set()
                    return
        threading.Thread(target=read, daemon=True).start()
        found.wait(timeout)
        self._output = (self._output or '') + ''.join(lines)
        return found.is_set()

    def wait_exit(self, timeout=20):
        """Wait for the node to exit by itself; return (exit code, output)."""
        out, _ = self.proc.communicate(timeout=timeout)
        self._output = out
        return self.proc.returncode, out


class Peer:
    """An in-process rclpy node that drives /clock and truth, and collects."""

    def __init__(self, name='test_peer'):
        self.node = Node(name)
        self.clock_pub = self.node.create_publisher(
            Clock, '/clock', QoSProfile(depth=100))
        self.received = {}

    def publisher(self, msg_type, topic, depth=100):
        """
        Return a reliable publisher on ``topic`` keeping the last ``depth`` messages.

        A burst longer than ``depth`` that the subscriber has not yet
        acknowledged loses its oldest messages at this end (reliable but
        keep-last), however deep the subscriber's queue.
        """
        return self.node.create_publisher(msg_type, topic, QoSProfile(depth=depth))

    def collect(self, msg_type, topic, qos=None):
        """Subscribe to ``topic`` (reliable unless ``qos``); keep every message."""
        box = self.received.setdefault(topic, [])
        self.node.create_subscription(
            msg_type, topic, box.append, qos or QoSProfile(depth=1000))
        return box

    def spin_for(self, seconds):
        """Process callbacks for ``seconds`` of wall time."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=0.01)

    def spin_until(self, predicate, timeout=10.0):
        """Process callbacks until ``predicate()``; return whether it held."""
        end = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > end:
                return False
            rclpy.spin_once(self.node, timeout_sec=0.01)
        return True

    def wait_connected(self, pub, sub_topic, proc, timeout=20.0):
        """
        Wait until the node subscribes to ``pub`` and publishes ``sub_topic``.

        A node on simulated time must also have subscribed to /clock: a tick
        published before that is lost to it, and it would start a step late.
        """
        def clock_seen():
            if not (proc.sim_time and proc.namespace):
                return True
            return any(e.node_namespace == proc.namespace
                       for e in self.node.get_subscriptions_info_by_topic('/clock'))

        def ready():
            if proc.proc.poll() is not None:
                raise RuntimeError(f'node exited early: {proc.wait_exit()[1]}')
            return (pub.get_subscription_count() > 0
                    and self.node.count_publishers(sub_topic) > 0 and clock_seen())
        assert self.spin_until(ready, timeout), 'node did not connect'
        self.spin_for(0.3)

    def set_clock(self, ns):
        """Publish /clock = ``ns`` nanoseconds."""
        self.clock_pub.publish(Clock(clock=stamp(ns)))

    def destroy(self):
        """Destroy the rclpy node."""
        self.node.destroy_node()


def node_statuses(box, hardware_id):
    """Return the DiagnosticStatus of ``hardware_id`` in DiagnosticArrays ``box``, oldest first."""
    return [m.status[0] for m in box if m.status[0].hardware_id == hardware_id]


def status_values(status):
    """Return {key: value} of a DiagnosticStatus."""
    return {kv.key: kv.value for kv in status.values}


def stamp(ns):
    """Return builtin_interfaces/Time for integer nanoseconds."""
    from builtin_interfaces.msg import Time
    return Time(sec=int(ns // NS), nanosec=int(ns % NS))


def stamp_ns(t):
    """Return integer nanoseconds of builtin_interfaces/Time."""
    return t.sec * NS + t.nanosec


# --- shared by the error-node tests -------------------------------------

DATUM = (40.75057, -73.99065, -23.0)
DATUM_ARG = 'datum:=[40.75057, -73.99065, -23.0]'
T0 = 1000  # simulated seconds at start


def start(ns, *params, extra=()):
    """Start the error node in namespace ``ns`` on /clock with ``params``."""
    args = ['--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true']
    for p in params:
        args += ['-p', p]
    return NodeProcess(args + list(extra))


def pose_msg(ns, east=0.0, north=0.0, up=0.0):
    """Return a PoseStamped at (east, north, up) stamped ``ns``."""
    m = PoseStamped()
    m.header.stamp = stamp(ns)
    m.header.frame_id = 'map'
    m.pose.position.x, m.pose.position.y, m.pose.position.z = east, north, up
    m.pose.orientation.w = 1.0
    return m


def drive(peer, pose_pub, fixes, seconds, start_s=T0, batch=1, position=None):
    """
    Publish pose then /clock each simulated second; wait for the fixes.

    The first step is waited for on its own: the node counts steps from the
    first clock reading it sees.
    """
    for k in range(start_s, start_s + seconds):
        e, n = position(k) if position else (0.0, 0.0)
        pose_pub.publish(pose_msg(k * NS, e, n))
        peer.set_clock(k * NS)
        if k == start_s or (k - start_s + 1) % batch == 0 \
                or k == start_s + seconds - 1:
            want = k * NS
            ok = peer.spin_until(
                lambda: fixes and stamp_ns(fixes[-1].header.stamp) >= want, 5.0)
            assert ok, f'no fix for step {k}'


def drive_agents(peer, pubs, seconds, ready=None, start_s=T0):
    """
    Publish every agent's pose (standing at the datum), then /clock, each simulated second.

    ``pubs``: {agent: pose publisher}, published in that order. After each
    clock step, wait up to 5 s for ``ready(k)`` (the step's fixes in, say),
    or without it spin 0.05 s. Returns the steps whose ``ready`` never came.
    """
    missed = []
    for k in range(start_s, start_s + seconds):
        for pub in pubs.values():
            pub.publish(pose_msg(k * NS))
        peer.set_clock(k * NS)
        if ready is None:
            peer.spin_for(0.05)
        elif not peer.spin_until(lambda: ready(k), 5.0):
            missed.append(k)
    return missed


def errors(fixes, truth_lat, truth_lon):
    """Return the north/east error (m) of each fix against the truth."""
    lat = np.array([f.latitude for f in fixes])
    lon = np.array([f.longitude for f in fixes])
    return np.stack(difference(lat, lon, truth_lat, truth_lon), axis=1)


def covariances_ne(fixes):
    """Return each fix's horizontal covariance as north/east (m, 2, 2), from ENU."""
    return np.array([np.array(f.position_covariance).reshape(3, 3)[:2, :2][::-1, ::-1]
                     for f in fixes])


def standing_fixes(peer, profile, steps, *params):
    """
    Return the fixes of a node serving ``profile`` to a pedestrian standing at DATUM.

    The node runs on /clock in a namespace of its own, with ``params``
    (``name:=value``); ``steps`` simulated seconds are driven, and the node
    must stop cleanly.
    """
    from sensor_msgs.msg import NavSatFix
    ns = unique_ns()
    node = start(ns, f'profile:={profile}', DATUM_ARG, *params)
    pub = peer.publisher(PoseStamped, f'{ns}/pose')
    box = peer.collect(NavSatFix, f'{ns}/fix')
    peer.wait_connected(pub, f'{ns}/fix', node)
    drive(peer, pub, box, steps)
    rc, out = node.stop()
    assert rc == 0, out
    return box


def replay_calibration_node(ns, out, *params):
    """
    Start the calibration node on /clock for a bag replayed by ``bag_play``.

    Pose truth about the datum [40.0, -74.0, 0.0] on /truth, fixes on /fix
    (the topics of ``bag_helpers.write_walk_bag``), the profile to ``out``;
    reliable subscriptions, so that no message of the replay is lost.
    """
    args = ['--ros-args', '-r', f'__ns:={ns}', '-p', 'use_sim_time:=true',
            '-p', 'datum:=[40.0, -74.0, 0.0]', '-p', f'output:={out}',
            '-p', 'input_reliability:=reliable',
            '-r', f'{ns}/pose:=/truth', '-r', f'{ns}/fix:=/fix']
    for p in params:
        args += ['-p', p]
    return NodeProcess(args, name='gps_calibration_node')

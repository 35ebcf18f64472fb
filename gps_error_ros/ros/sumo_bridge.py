"""
``gps_error_sumo``: SUMO live in ROS 2, its people as truth topics.

Runs SUMO (the ``eclipse-sumo`` wheel, the optional extra ``sumo``) on a
``.sumocfg`` through TraCI and, after each SUMO step:

* publishes every person's position (and each vehicle's, with
  ``vehicle_prefix``) as truth on ``PREFIX/<id>/pose`` (PoseStamped in a
  local east-north-up frame about ``datum``) or ``PREFIX/<id>/fix_truth``
  (NavSatFix), stamped with SUMO's time of the step;
* then publishes that time on ``/clock``.

A topic appears when its agent enters SUMO and is destroyed when it leaves
(once its reliable subscribers have acknowledged its last positions, or
after ``RETIRE_TIMEOUT_S``), so the error node's ``agent_pattern``
(``/peds/*/pose``) serves the people as they walk. The time a position
carries is the one SUMO's FCD output gives it: the simulation time before
``simulationStep()`` (TraCI's ``getTime()`` is one step later after it), so
``gps_error simulate`` on the run's own FCD output gives the node's errors
(same seed and profile).

Georeference: with a projected network (``<location projParameter>``) a
position goes network x/y -> lon/lat -> ENU about ``datum`` (default: the
network's x=0, y=0); a network without a projection needs ``datum`` and its
x/y are east/north metres from it.

A SUMO id that is not a valid ROS name token (``0``, ``ped.1``) is published
under an encoded name (:func:`ros_name`) and logged; since the error node
keys its streams by the topic's name, use ids that are valid tokens (e.g.
``randomTrips.py --prefix p``) where the node's errors must match
``gps_error simulate`` on the FCD, which keys them by SUMO's id.
"""

from collections.abc import Sequence
import math
import os
from pathlib import Path
import re
import signal
import sys
import time
from typing import Any

from geometry_msgs.msg import PoseStamped
import numpy as np
import rclpy
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.model.geodesy import GeodesyError
from gps_error_ros.ros.conversions import to_stamp
from gps_error_ros.ros.lifecycle import command_line_problem, wants_help
from gps_error_ros.ros.parameter_docs import help_text
from gps_error_ros.ros.parameters import ConfigError, declare, SUMO_NODE_PARAMS
from gps_error_ros.ros.topics import CLOCK_PUB_QOS, help_rows, SUMO_TRUTH_QOS
from gps_error_ros.sim.sumo_scenario import (Georeference, INSTALL_HINT, net_file,
                                             ScenarioError, sumo_tool, SumoMissing)

NS = 1_000_000_000
#: Wall seconds waited after a new agent's topic is matched (see _wait_for_match).
MATCH_SETTLE_S = 0.2
#: Wall seconds a departed agent's publisher is kept, at most, for its last
#: poses to be acknowledged before it is destroyed (see _retire).
RETIRE_TIMEOUT_S = 2.0
_TOKEN = re.compile(r'[A-Za-z_][A-Za-z0-9_]*\Z')


def ros_name(sumo_id: str) -> str:
    """
    Return the ROS name token for a SUMO id: the id itself when it is one.

    Otherwise ``id_`` and the id's UTF-8 bytes in hex (``0`` -> ``id_30``),
    so that two different ids never share a topic.
    """
    if _TOKEN.match(sumo_id) and '__' not in sumo_id:
        return sumo_id
    return 'id_' + sumo_id.encode().hex()


class Kind:
    """One kind of SUMO agent (persons or vehicles): its TraCI domain and topics."""

    def __init__(self, domain: Any, prefix: str, msg_type: Any, leaf: str) -> None:
        self.domain, self.prefix = domain, prefix.rstrip('/')
        self.msg_type, self.leaf = msg_type, leaf
        self.pubs: dict[str, Any] = {}          # SUMO id -> publisher
        self.names: dict[str, str] = {}         # ROS name -> SUMO id (to refuse a clash)


class SumoBridge(Node):
    """Steps SUMO and publishes its agents' truth and its clock."""

    def __init__(self, stop: Sequence[object] = ()) -> None:
        super().__init__('gps_error_sumo')
        self.stop = stop            # non-empty once a signal asked to stop
        cfg = declare(self, SUMO_NODE_PARAMS)
        if not cfg['sumocfg']:
            raise ConfigError('parameter \'sumocfg\' is required: expected the path '
                              'of a SUMO scenario (.sumocfg)')
        if not Path(cfg['sumocfg']).is_file():
            raise ConfigError(f'parameter \'sumocfg\': {cfg["sumocfg"]} is not a file')
        self.cfg = cfg
        try:
            self.geo = Georeference(net_file(cfg['sumocfg']), cfg['datum'])
        except (ScenarioError, GeodesyError) as exc:
            raise ConfigError(str(exc)) from None
        try:
            import traci
        except ImportError:
            raise ConfigError(INSTALL_HINT) from None
        self.traci = traci
        self.position, self.angle = traci.constants.VAR_POSITION, traci.constants.VAR_ANGLE
        navsat = cfg['output_type'] == 'navsatfix'
        msg_type, leaf = (NavSatFix, 'fix_truth') if navsat else (PoseStamped, 'pose')
        self.kinds = [Kind(traci.person, cfg['person_prefix'], msg_type, leaf)]
        if cfg['vehicle_prefix']:
            self.kinds.append(Kind(traci.vehicle, cfg['vehicle_prefix'], msg_type, leaf))
        self.clock = self.create_publisher(Clock, '/clock', CLOCK_PUB_QOS)
        self.steps = self.published = 0
        self.retiring: list[tuple[float, Any]] = []   # (wall deadline, publisher) departed
        lat, lon, alt = self.geo.datum
        self.get_logger().info(f'datum of the poses: [{lat:.9f}, {lon:.9f}, {alt:.3f}] '
                               f'(give the error node the same)')

    # --- SUMO ------------------------------------------------------------

    def start_sumo(self) -> None:
        """Start SUMO on the scenario through TraCI."""
        try:
            binary = self.cfg['sumo_binary'] or sumo_tool('sumo')
        except SumoMissing as exc:
            raise ConfigError(str(exc)) from None
        cmd = [binary, '-c', self.cfg['sumocfg'],
               '--no-step-log', 'true'] + list(self.cfg['sumo_args'] or [])
        try:
            self.traci.start(cmd, label=f'gps_error_sumo_{os.getpid()}')
        except (self.traci.exceptions.TraCIException, self.traci.exceptions.FatalTraCIError,
                OSError) as exc:
            raise ConfigError(f'SUMO did not start ({" ".join(cmd)}): {exc}') from None

    def run(self) -> int:
        """Step SUMO to its end; return the number of steps."""
        sim = self.traci.simulation
        self._wait_for_clock()
        t0, wall0 = None, time.monotonic()
        end = sim.getEndTime()
        while (not self.stop and sim.getMinExpectedNumber() > 0
               and (end < 0 or sim.getTime() < end)):
            t = sim.getTime()
            if t0 is None:
                t0 = t
                self.get_logger().info(f'SUMO begins at {t:g} s (give the error node '
                                       f'start_time:={float(t)!r})')
                if t <= 0:
                    self.get_logger().warning(
                        'SUMO begins at 0 s, which ROS reads as "no clock yet": the error '
                        'node\'s first step is SUMO\'s second; begin at 1 s or later '
                        '(<begin value="1"/>) to have fixes from the first')
            self.traci.simulationStep()
            self.steps += 1
            stamp = to_stamp(int(round(t * NS)))
            for kind in self.kinds:
                self._publish_kind(kind, stamp)
            self.clock.publish(Clock(clock=stamp))
            if self.cfg['speed'] > 0:
                lag = (t - t0 + sim.getDeltaT()) / self.cfg['speed'] - (time.monotonic() - wall0)
                if lag > 0:
                    time.sleep(lag)
        return self.steps

    def close(self) -> None:
        """Close TraCI (SUMO ends) and destroy the agents' publishers."""
        try:
            self.traci.close()
        except Exception:       # SUMO already gone: nothing left to close
            pass
        for kind in self.kinds:
            self._retire(list(kind.pubs.values()), wait=True)
            kind.pubs.clear()

    # --- internals -------------------------------------------------------

    def _wait_for_clock(self) -> None:
        want = self.cfg['wait_for_clock']
        if want:
            self.get_logger().info(f'waiting for {want} /clock subscriber(s)')
            while self.clock.get_subscription_count() < want and not self.stop:
                time.sleep(0.05)

    def _publish_kind(self, kind: Kind, stamp: Any) -> None:
        ids = list(kind.domain.getIDList())
        present = set(ids)
        gone = [i for i in kind.pubs if i not in present]
        self._retire([kind.pubs.pop(i) for i in gone])
        for i in gone:
            del kind.names[ros_name(i)]
        new = [i for i in ids if i not in kind.pubs]
        for i in new:
            kind.pubs[i] = self._create_agent(kind, i)
            # one TraCI round trip per step for all agents, not two per agent
            kind.domain.subscribe(i, (self.position, self.angle))
        if new:
            self._wait_for_match([kind.pubs[i] for i in new])
        if not ids:
            return
        values = kind.domain.getAllSubscriptionResults()
        xy = np.array([values[i][self.position] for i in ids], dtype=float)
        angle = np.array([values[i][self.angle] for i in ids], dtype=float)
        east, north, up, lat, lon = self.geo.convert(xy[:, 0], xy[:, 1])
        for j, i in enumerate(ids):
            kind.pubs[i].publish(self._message(kind, stamp, east[j], north[j], up[j],
                                               lat[j], lon[j], angle[j]))
        self.published += len(ids)

    def _retire(self, pubs: Sequence[Any], wait: bool = False) -> None:
        """
        Destroy departed agents' publishers once their last poses are acknowledged.

        A writer destroyed with poses not yet acknowledged takes them with it:
        on a loaded machine a person's last one or two poses were lost so, and
        their steps got no fix. ``pubs`` join the publishers waiting; every
        call destroys those whose reliable subscribers have acknowledged all
        (best-effort ones send no acknowledgements: at once) or whose
        ``RETIRE_TIMEOUT_S`` has passed. Nothing waits, so SUMO steps on;
        with ``wait`` (the bridge closing) each waits up to its deadline and
        all are destroyed.
        """
        now = time.monotonic()
        self.retiring += [(now + RETIRE_TIMEOUT_S, pub) for pub in pubs]
        keep = []
        for deadline, pub in self.retiring:
            left = max(0.0, deadline - time.monotonic()) if wait else 0.0
            if pub.wait_for_all_acked(Duration(seconds=left)) or wait or now >= deadline:
                self.destroy_publisher(pub)
            else:
                keep.append((deadline, pub))
        self.retiring = keep

    def _create_agent(self, kind: Kind, sumo_id: str) -> Any:
        name = ros_name(sumo_id)
        if name in kind.names:
            raise RuntimeError(f'SUMO ids {kind.names[name]!r} and {sumo_id!r} share the '
                               f'ROS name {name!r}')
        kind.names[name] = sumo_id
        if name != sumo_id:
            self.get_logger().warning(
                f'SUMO id {sumo_id!r} is not a valid ROS name token: published as '
                f'{name!r}', throttle_duration_sec=5.0)
        return self.create_publisher(kind.msg_type, f'{kind.prefix}/{name}/{kind.leaf}',
                                     SUMO_TRUTH_QOS)

    def _wait_for_match(self, pubs: Sequence[Any]) -> None:
        """
        Wait until ``match_node`` subscribes to the topic of every one of ``pubs``.

        Its subscription must be in the graph and matched by our publisher:
        with other subscribers (a recorder), a count alone says nothing.
        """
        timeout, who = self.cfg['match_timeout'], self.cfg['match_node']
        if not timeout:
            return
        deadline = time.monotonic() + timeout
        waiting = list(pubs)
        while waiting and time.monotonic() < deadline and not self.stop:
            waiting = [p for p in waiting if not self._matched(p, who)]
            if waiting:
                time.sleep(0.02)
        if waiting:
            self.get_logger().warning(
                f'{len(waiting)} new topic(s) not subscribed by {who} after {timeout:g} s, '
                f'e.g. {waiting[0].topic_name}: published anyway', throttle_duration_sec=5.0)
        else:
            # the node made the agent's fix publisher with its subscription: give
            # it a moment to meet that topic's subscribers, or a first fix sent
            # before they match is lost to them (seen under load in CI)
            time.sleep(MATCH_SETTLE_S)

    def _matched(self, pub: Any, who: str) -> bool:
        subs = self.get_subscriptions_info_by_topic(pub.topic_name)
        return (any(s.node_name == who for s in subs)
                and pub.get_subscription_count() >= len(subs))

    def _message(self, kind: Kind, stamp: Any, east: float, north: float, up: float,
                 lat: float, lon: float, angle_deg: float) -> Any:
        if kind.msg_type is NavSatFix:
            msg = NavSatFix()
            msg.header.stamp, msg.header.frame_id = stamp, self.cfg['frame_id']
            msg.status.status = NavSatStatus.STATUS_FIX
            msg.status.service = NavSatStatus.SERVICE_GPS
            msg.latitude, msg.longitude, msg.altitude = float(lat), float(lon), 0.0
            msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_UNKNOWN
            return msg
        msg = PoseStamped()
        msg.header.stamp, msg.header.frame_id = stamp, self.cfg['frame_id']
        p = msg.pose.position
        p.x, p.y, p.z = float(east), float(north), float(up)
        # SUMO's angle: degrees clockwise from north; ENU yaw: counter-clockwise from east
        yaw = math.radians(90.0 - angle_deg) if math.isfinite(angle_deg) else 0.0
        msg.pose.orientation.z, msg.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        return msg


HELP = help_text(
    'gps_error_sumo',
    'runs SUMO on a scenario and publishes its people (and vehicles) as truth '
    'topics and its time on /clock, for gps_error_node with agent_pattern.',
    SUMO_NODE_PARAMS,
    help_rows('gps_error_sumo'),
    'gps_error_sumo --ros-args -p sumocfg:=scenario.sumocfg -p wait_for_clock:=1 '
    '-p match_timeout:=5.0')


def main(args: Sequence[str] | None = None) -> int:
    """
    Run SUMO to its end, publishing as it goes; return the exit code.

    0 at SUMO's end or after Ctrl-C / SIGTERM (SUMO closed first); 2 for a
    bad parameter, a command line rcl cannot parse, or SUMO not starting.
    """
    if wants_help(args):
        print(HELP)
        return 0
    try:
        rclpy.init(args=None if args is None else list(args),
                   signal_handler_options=SignalHandlerOptions.NO)
    except RuntimeError as exc:
        print(f'gps_error_sumo: cannot parse the command line: '
              f'{command_line_problem(exc)}', file=sys.stderr)
        return 2
    logger = rclpy.logging.get_logger('gps_error_sumo')
    stop: list[bool] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.append(True))
    node: SumoBridge | None = None
    code = 0
    try:
        node = SumoBridge(stop)
        node.start_sumo()
        steps = node.run()
        logger.info(f'{"stopped" if stop else "SUMO ended"} after {steps} steps; '
                    f'{node.published} truth messages published')
    except ConfigError as exc:
        logger.fatal(str(exc))
        code = 2
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == '__main__':
    raise SystemExit(main())

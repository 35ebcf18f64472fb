"""
``gps_error_node``: ground-truth poses in, smartphone-like NavSatFix out.

Subscribes to the truth (``pose``, ``odom`` or ``fix_truth`` by
``input_type``), steps the profile's AR error model on the ROS clock and
publishes ``sensor_msgs/NavSatFix`` on ``fix``. With the ``agents``
parameter one node serves a crowd: agent ``A`` reads ``A/pose`` and publishes
``A/fix``, one timer steps every agent together (vectorised), and the agents'
subscriptions are drained once per step rather than waking the executor per
message. All arithmetic lives in :mod:`gps_error_ros.sim.engine`; this module
converts messages and parameters.
"""

from collections.abc import Mapping, Sequence
from functools import partial
import math
import re
import secrets
import time
from typing import Any

from geometry_msgs.msg import PoseWithCovarianceStamped, TwistWithCovarianceStamped
import numpy as np
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.about_truth import model_about_truth, reported_mean
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.model.profiles import load_profile, ProfileError
from gps_error_ros.model.streams import agent_key
from gps_error_ros.model.zoned import zoned_errors
from gps_error_ros.model.zones import load_zone_map, ZoneMap, ZoneMapError
from gps_error_ros.ros import cdr, conversions, nmea_stream
from gps_error_ros.ros.agent_watch import AgentWatcher, PatternAgents
from gps_error_ros.ros.diagnostics import (Counters, DiagnosticsPublisher, ERROR, OK,
                                           Report, WARN)
from gps_error_ros.ros.fix_output import FixOutput, profile_carries, start_summary
from gps_error_ros.ros.lifecycle import run_node
from gps_error_ros.ros.node_faults import NodeFaults
from gps_error_ros.ros.profile_group import ProfileGroup
from gps_error_ros.ros.parameter_docs import help_text
from gps_error_ros.ros.parameters import (
    ConfigError, datum_frame, declare, ERROR_NODE_PARAMS, spec_by_name, WARN_PERIOD_S)
from gps_error_ros.ros.rclpy_adapter import (DrainedByTheNode, handles, take_raw,
                                             WaitsOnUndrained)
from gps_error_ros.ros.topics import FIX_QOS, help_rows, TRUTH_QOS
from gps_error_ros.ros.truth_frame import TruthFrame
from gps_error_ros.sim.engine import FixEngine, NS
from gps_error_ros.sim.faults import FaultOverlay
from gps_error_ros.traces.validity import usable_fix, usable_pose

#: /diagnostics counters that are the node working as it should (an outage is
#: the profile's availability model, not a fault).
NOT_TROUBLE = ('fixes published', 'no-fix messages published (outages)',
               'steps in an outage', 'fixes touched by injected faults')
#: Wall seconds between two looks at the graph for agent_pattern.
WATCH_PERIOD_S = 1.0
#: Slots an agent_pattern node starts with (doubled whenever they run out).
FIRST_SLOTS = 16


AGENT_NAME = re.compile(r'^[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*$')


class GpsErrorNode(WaitsOnUndrained, PatternAgents, Node):
    """The error node, for one agent or a crowd (see the module docstring)."""

    polled = False

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('gps_error_node', **kwargs,
                         automatically_declare_parameters_from_overrides=True)
        cfg = declare(self, ERROR_NODE_PARAMS)
        self._specs = spec_by_name(ERROR_NODE_PARAMS)
        self.frame_id = cfg['frame_id']
        self.max_pose_age = cfg['max_pose_age']
        self.start_time = cfg['start_time']
        self.late_reported_start = False
        self.began_ns: int | None = None        # the streams' first step, once logged
        self.input_type = cfg['input_type']
        self.fix_reliability = cfg['fix_reliability']
        self.truth_qos = TRUTH_QOS[cfg['input_reliability']]
        pattern = self._agent_pattern(cfg)
        if pattern is None:
            self.agents = self._agent_names(cfg['agents'])
            profiles = self._agent_profile_specs(cfg)
        else:
            self.agents = [None] * FIRST_SLOTS     # free slots: agents come later
            profiles = [cfg['profile']] * FIRST_SLOTS
        seed = cfg['seed']
        if seed < 0:
            seed = secrets.randbits(63)
            self.get_logger().info(f'no seed given: using seed {seed}')
        self.seed = seed
        self.faults = NodeFaults(self, cfg['fault_schedule'], cfg['faults'],
                                 period_ns=int(round(NS / cfg['rate'])))
        self._build_groups(cfg, profiles, active=pattern is None)
        # the datum is checked after the profiles: a bad profile is named first
        self.frame: LocalTangentFrame | None = None
        if self.input_type != 'navsatfix':
            self.frame = datum_frame(cfg['datum'], self.input_type)
        self.truth_frame = TruthFrame.of(self, cfg, self.input_type)
        self.pose_frame_id = cfg['pose_frame_id'].strip()
        if self.pose_frame_id and self.frame is None:
            self.frame = datum_frame(cfg['datum'], self.input_type,
                                     'pose_frame_id (the pose output is about the datum)')
        self.polled = pattern is not None or len(self.agents) > 1 or self.agents != ['']
        self._create_topics()
        self.tick_time: list[float] = [0, 0.0, 0.0]      # ticks, total s, max s
        self.invalid_truth = 0              # truth messages that could not be used
        self.fix_output = FixOutput(self, cfg['outage_output'],
                                    self.fix_reliability == 'best_effort',
                                    cfg['covariance_mode'], per_fix=bool(cfg['zones']),
                                    about_truth=cfg['covariance_about'] == 'truth')
        self.fix_output.templates(self.frame_id)
        self.nmea = nmea_stream.open_for(self, cfg['nmea_port'], pattern is not None)
        self.timer = self.create_timer(1.0 / cfg['rate'], self._on_timer)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.watcher: AgentWatcher | None = None
        if pattern is not None:
            self.watcher = AgentWatcher(self, pattern, cfg['agent_timeout'])
            self.watch_timer = self.create_timer(WATCH_PERIOD_S, self.watcher.scan,
                                                 clock=steady)
        self.counters = Counters()
        self.diagnostics = DiagnosticsPublisher(self, 'fixes', self._report)
        self.add_on_set_parameters_callback(self._check_new_parameters)
        self.add_post_set_parameters_callback(self._apply_new_parameters)
        self._log_start(cfg, profiles)

    def _build_groups(self, cfg: Mapping[str, Any], profiles: Sequence[str], active: bool = True
                      ) -> None:
        """Make one engine per distinct profile, each over its own agents."""
        self.groups = []
        # agent -> (group, local index)
        self.slot: list[tuple[int, int]] = [(0, 0)] * len(self.agents)
        zone_map = self._zone_map(cfg)
        for spec in dict.fromkeys(profiles):
            zones = None
            try:
                profile = load_profile(spec)
                # reported: the phone's radius follows the plain predictive scale
                about = model_about_truth(cfg['covariance_about'], cfg['covariance_mode'])
                if zone_map is None:
                    model = profile.model(about_truth=about)
                else:
                    profile, model, zones = zoned_errors(zone_map, profile,
                                                         cfg['covariance_mode'], about)
            except ProfileError as exc:
                name = 'agent_profiles' if cfg['agent_profiles'] else 'profile'
                raise ConfigError(f'parameter {name!r} ({spec!r}): {exc}') from None
            except ZoneMapError as exc:
                raise ConfigError(f'parameter \'zones\': {exc}') from None
            reported = profile.reported_accuracy if cfg['covariance_mode'] == 'reported' \
                else None
            if cfg['covariance_mode'] == 'reported' and reported is None:
                raise ConfigError(
                    f'parameter \'covariance_mode\' (\'reported\'): profile {spec!r} has no '
                    f'reported_accuracy section; calibrate one from a trace with an '
                    f'accuracy or hdop column, or choose stationary or conditional')
            members = [i for i, p in enumerate(profiles) if p == spec]
            keys = [agent_key(self.seed, agent) if active and (agent := self.agents[i]) is not None
                    else 0 for i in members]
            engine = FixEngine(model, keys, rate=cfg['rate'],
                               model_rate=profile.rate_hz,
                               max_pose_age=cfg['max_pose_age'], active=active,
                               start_ns=(None if cfg['start_time'] < 0
                                         else int(round(cfg['start_time'] * NS))),
                               velocity=profile.velocity,
                               conditional_cov=cfg['covariance_mode'] == 'conditional',
                               zones=zones, reported=reported,
                               reported_bias=None if reported is None else
                               reported_mean(model, cfg['covariance_about']),
                               faults=FaultOverlay(self.faults.faults, self.seed))
            cov, cov_type = conversions.enu_covariance(
                model.stationary_cov, profile.vertical_variance(model))
            g = len(self.groups)
            self.groups.append(ProfileGroup(engine, np.array(members), cov, cov_type,
                                            spec, profile_carries(profile)))
            for local, i in enumerate(members):
                self.slot[i] = (g, local)
        self.slot_group = np.array([g for g, _ in self.slot])
        self.slot_local = np.array([local for _, local in self.slot])

    def _zone_map(self, cfg: Mapping[str, Any]) -> ZoneMap | None:
        """Return the zone map of parameter ``zones``, or None."""
        if not cfg['zones'].strip():
            return None
        try:
            return load_zone_map(cfg['zones'])
        except ZoneMapError as exc:
            raise ConfigError(f'parameter \'zones\': {exc}') from None

    def _create_topics(self) -> None:
        """Create each agent's truth subscription and fix publisher."""
        topic = conversions.TRUTH_INPUTS[self.input_type][0]
        # rclpy gives every publisher and subscription QoS-event handlers (to
        # log incompatible QoS); each is a waitable the executor re-adds to its
        # wait set on every wake, which with thousands of topics costs most of
        # a core. A crowd goes without them.
        self.drained = DrainedByTheNode()
        self.sub_events = SubscriptionEventCallbacks(use_default_callbacks=not self.polled)
        self.pub_events = PublisherEventCallbacks(use_default_callbacks=not self.polled)
        n = len(self.agents)
        self.subs, self.pubs = [None] * n, [None] * n
        self.sub_handles, self.pub_handles = [None] * n, [None] * n
        self.vel_pubs = [None] * n      # with a profile velocity section
        self.pose_pubs = [None] * n     # with pose_frame_id
        for i, name in enumerate(self.agents):
            if name is not None:
                prefix = f'{name}/' if name else ''
                self._open(i, prefix + topic, prefix + 'fix')

    def _open(self, i: int, truth_topic: str, fix_topic: str) -> None:
        """Create agent ``i``'s truth subscription and fix publisher."""
        msg_type = conversions.TRUTH_INPUTS[self.input_type][1]
        # A crowd's truth subscriptions are in a callback group that executors
        # never run, and left out of what they wait on (``subscriptions``):
        # the node drains them itself once per step.
        sub = self.create_subscription(
            msg_type, truth_topic, partial(self._on_truth, i), self.truth_qos,
            callback_group=self.drained if self.polled else None,
            raw=self.polled, event_callbacks=self.sub_events)
        pub = self.create_publisher(NavSatFix, fix_topic, FIX_QOS[self.fix_reliability],
                                    event_callbacks=self.pub_events)
        self.subs[i], self.pubs[i] = sub, pub
        self.sub_handles[i] = handles(sub)
        self.pub_handles[i] = pub.handle
        if self.groups[self.slot_group[i]].engine.vel is not None:
            self.vel_pubs[i] = self.create_publisher(
                TwistWithCovarianceStamped, fix_topic[:-len('fix')] + 'vel',
                FIX_QOS[self.fix_reliability], event_callbacks=self.pub_events)
        if self.pose_frame_id:
            self.pose_pubs[i] = self.create_publisher(
                PoseWithCovarianceStamped, fix_topic + '_pose',
                FIX_QOS[self.fix_reliability], event_callbacks=self.pub_events)

    def _log_start(self, cfg: Mapping[str, Any], profiles: Sequence[str]) -> None:
        """Log what the node serves: each profile, its agents and its SD."""
        topic = conversions.TRUTH_INPUTS[self.input_type][0]
        who = (f'{len(self.agents)} agents' if self.polled else
               f'input {self.input_type} on {self.resolve_topic_name(topic)}')
        self.get_logger().info(start_summary(self.groups, cfg, who, self.polled, self.seed))

    def _agent_names(self, names: Sequence[str]) -> list[str | None]:
        if not names:
            return ['']
        for n in names:
            if not AGENT_NAME.match(n):
                raise ConfigError(
                    f'parameter \'agents\': invalid agent name {n!r}: expected '
                    f'a relative ROS name (letters, digits, _ and /, starting '
                    f'with a letter)')
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ConfigError(f'parameter \'agents\': duplicate names {dup}')
        return list(names)

    def _agent_profile_specs(self, cfg: Mapping[str, Any]) -> list[str]:
        per_agent = cfg['agent_profiles']
        if not per_agent:
            return [cfg['profile']] * len(self.agents)
        if len(per_agent) != len(self.agents) or not cfg['agents']:
            raise ConfigError(
                f'parameter \'agent_profiles\': {len(per_agent)} entries: '
                f'expected one per agent in \'agents\' ({len(cfg["agents"])})')
        return list(per_agent)

    # --- callbacks -------------------------------------------------------

    def _datum(self) -> LocalTangentFrame:
        """Return the frame poses are about (every input_type but navsatfix has one)."""
        if self.frame is None:
            raise ValueError('poses need the datum frame; input_type navsatfix has none')
        return self.frame

    def now_ns(self) -> int:
        """Return the ROS clock's time in ns."""
        return self.get_clock().now().nanoseconds

    def _on_truth(self, agent: int, msg: Any) -> bool:
        """Store one truth message of ``agent``; True if it was kept."""
        if not self.truth_frame.keep(msg.header.frame_id):
            return False
        try:
            if self.input_type == 'navsatfix':
                lat, lon, alt = conversions.navsatfix_position(msg)
            else:
                pose = msg.pose if self.input_type == 'pose' else msg.pose.pose
                east, north, up = conversions.pose_position(pose)
                lat, lon, alt = self._datum().to_geodetic(east, north, up)
                if not all(map(math.isfinite, (lat, lon, alt))):
                    raise ValueError('position outside the datum frame\'s range')
        except ValueError as exc:
            self.invalid_truth += 1
            self.get_logger().warning(f'dropped a truth message: {exc}',
                                      throttle_duration_sec=WARN_PERIOD_S)
            g, local = self.slot[agent]
            self.groups[g].engine.note_invalid(
                local, conversions.stamp_ns(msg.header.stamp) or self.now_ns())
            return False
        stamp = conversions.stamp_ns(msg.header.stamp) or self.now_ns()
        g, local = self.slot[agent]
        if not self.groups[g].engine.add_truth(local, stamp, lat, lon, alt):
            self.get_logger().warning(
                'dropped a truth message stamped at or before the newest one (out '
                'of order or duplicate) or more than 60 s ahead of the clock',
                throttle_duration_sec=WARN_PERIOD_S)
            return False
        if not self.polled:
            self.fix_output.publish(g, self.groups[g].engine.resolve(self.now_ns()))
        return True

    def _drain(self) -> None:
        """
        Take every waiting truth message of every agent (polled mode).

        Messages are taken serialized and parsed in place (:mod:`.cdr`), and
        converted and stored for all agents at once.
        """
        slots: list[int] = []
        raws: list[bytes] = []
        # The handles are taken from directly (the rclpy adapter): this node
        # owns the subscriptions and never destroys them while draining.
        for i, held in enumerate(self.sub_handles):
            if held is None:
                continue
            raw = take_raw(*held)
            while raw is not None:
                raws.append(raw)
                slots.append(i)
                raw = take_raw(*held)
        if not raws:
            return
        stamps, values, parsed = cdr.parse_batch(self.input_type, raws)
        if not parsed.all():
            self.invalid_truth += int((~parsed).sum())
            self.get_logger().warning(
                f'dropped {int((~parsed).sum())} truth message(s) that could not be '
                f'parsed', throttle_duration_sec=WARN_PERIOD_S)
        parsed &= self.truth_frame.keep_batch(raws)      # a pose in another frame, refused
        agents = np.array(slots)
        now = self.now_ns()
        stamps[stamps == 0] = now
        if self.input_type == 'navsatfix':
            ok = parsed & usable_fix(values[:, 0], values[:, 1], values[:, 2])
            coords = values[:, 1:4].copy()
            coords[~np.isfinite(coords[:, 2]), 2] = 0.0
        else:
            ok = parsed & usable_pose(values[:, 0:3], values[:, 3:7])
            lat, lon, alt = self._datum().to_geodetic(values[:, 0], values[:, 1], values[:, 2])
            coords = np.stack([lat, lon, alt], axis=1)
            ok &= np.isfinite(coords).all(axis=1)
        if not ok[parsed].all():
            self.invalid_truth += int((~ok[parsed]).sum())
            self.get_logger().warning(
                f'dropped {int((~ok[parsed]).sum())} truth message(s) with non-finite '
                f'or invalid values', throttle_duration_sec=WARN_PERIOD_S)
        local = self.slot_local[agents]
        group_of = self.slot_group[agents]
        for g, group in enumerate(self.groups):
            bad = parsed & ~ok & (group_of == g)
            if bad.any():
                group.engine.note_invalid(local[bad], stamps[bad])
            mine = ok & (group_of == g)
            if mine.any():
                kept = group.engine.add_truth_batch(local[mine], stamps[mine], coords[mine])
                if not kept.all():
                    self.get_logger().warning(
                        'dropped truth messages stamped at or before the newest '
                        'one of their agent, or more than 60 s ahead of the clock',
                        throttle_duration_sec=WARN_PERIOD_S)

    def _on_timer(self) -> None:
        t0 = time.perf_counter()
        if self.polled:
            self._drain()
        now = self.now_ns()
        resets = self._total('resets')
        for g, group in enumerate(self.groups):
            self.fix_output.publish(g, group.engine.on_clock(now))
        began = self.groups[0].engine.began_ns
        if began is not None and began != self.began_ns:
            self.began_ns = began
            self.get_logger().info(
                f'the error streams begin at ROS time {began / 1e9:.3f} s'
                + ('' if self.start_time >= 0 else
                   ' (the first clock reading: set start_time for fixes that do not '
                   'depend on when the node read it)'))
        self.truth_frame.warn_of_gaps(self._total('late_truth'), self._total('invalid_gaps'),
                                      self.max_pose_age)
        if self._total('late_start') and not self.late_reported_start:
            self.late_reported_start = True
            self.get_logger().warning(
                f'the first clock reading ({now / 1e9:.3f} s) is more than 1000 steps '
                f'after start_time: the streams begin at it instead')
        if self._total('resets') > resets:
            self.get_logger().warning(
                f'the clock went backwards (to {now / 1e9:.3f} s): truth history '
                f'and pending steps discarded, models restarted',
                throttle_duration_sec=WARN_PERIOD_S)
        dt = time.perf_counter() - t0
        self.tick_time[0] += 1
        self.tick_time[1] += dt
        self.tick_time[2] = max(self.tick_time[2], dt)

    def _total(self, counter: str) -> int:
        """Return an EngineStats counter summed over the profile groups."""
        return sum(getattr(g.engine.stats, counter) for g in self.groups)

    def summary(self) -> str:
        """Return a one-line account of the run (logged at shutdown)."""
        ticks, total, worst = self.tick_time
        mean_ms = 1e3 * total / ticks if ticks else 0.0
        t = self._total
        out = self.fix_output
        return (f'{ticks} timer ticks, {t("steps")} model steps, '
                f'{out.fixes + out.no_fix} NavSatFix published ({out.fixes} with a '
                f'position, {out.no_fix} NO_FIX), {t("no_fix")} steps in an outage, '
                f'{out.refused} non-finite fixes refused, '
                f'{t("skipped_no_truth")} skipped without truth, '
                f'{t("dropped_out_of_order")} truth messages out of '
                f'order, {t("dropped_future")} stamped in the future, '
                f'{self.invalid_truth} invalid (not finite), '
                f'{self.truth_frame.others} in another frame than truth_frame, '
                f'{t("resets")} clock resets, '
                f'{t("late_truth")} times truth came after its step '
                f'was skipped; '
                f'wall time per '
                f'tick {mean_ms:.3f} ms mean, {1e3 * worst:.3f} ms max')

    def _report(self) -> Report:
        """Return the /diagnostics status: what was published and skipped."""
        t = self._total
        total = {
            'fixes published': self.fix_output.fixes,
            'no-fix messages published (outages)': self.fix_output.no_fix,
            'steps in an outage': t('no_fix'),
            'steps skipped without truth': t('skipped_no_truth'),
            'truth dropped (out of order)': t('dropped_out_of_order'),
            'truth dropped (stamped in the future)': t('dropped_future'),
            'truth dropped (invalid)': self.invalid_truth,
            'truth in another frame than truth_frame': self.truth_frame.others,
            'truth came after its step was skipped': t('late_truth'),
            'clock resets': t('resets'),
            'non-finite fixes refused': self.fix_output.refused,
            'fixes touched by injected faults': NodeFaults.touched(self.groups),
        }
        recent = {k: self.counters.delta(k, v) for k, v in total.items()}
        served = sum(a is not None for a in self.agents)
        values: dict[str, Any] = {'profile': ', '.join(g.profile for g in self.groups),
                                  'seed': self.seed, 'agents served': served}
        zmap = self.groups[0].engine.zone_map
        if zmap is not None:
            values['zones'] = f'{zmap.path} ({len(zmap)})'
        if self.watcher is not None:
            values.update({'agent_pattern': self.watcher.pattern.text,
                           'agents stale': self.watcher.stale,
                           'agents released': self.watcher.released})
        values.update(total)
        ticks, spent, worst = self.tick_time
        values['ROS time (s)'] = self.now_ns() / 1e9
        values['timer ticks'] = ticks
        values['wall time per tick, mean (ms)'] = 1e3 * spent / ticks if ticks else 0.0
        values['wall time per tick, max (ms)'] = 1e3 * worst
        level, message = OK, (f'{served} agent(s) served, {recent["fixes published"]} '
                              f'fix(es) since the last report')
        trouble = [f'{recent[k]} {k}' for k in recent
                   if recent[k] and k not in NOT_TROUBLE]
        if self.watcher is not None and self.watcher.stale:
            trouble.append(f'{self.watcher.stale} agent(s) stale')
        if trouble:
            level = ERROR if recent['non-finite fixes refused'] else WARN
            message += '; ' + ', '.join(trouble)
        return Report(level, message, values)

    def _check_new_parameters(self, params: Sequence[Any]) -> SetParametersResult:
        """
        Reject a runtime change that the descriptors cannot express.

        rclpy already refuses read-only parameters, wrong types and values
        outside a declared range; this adds the choices and non-empty strings.
        """
        for p in params:
            spec = self._specs.get(p.name)
            reason = spec.check(p.value) if spec is not None else None
            if p.name == 'faults' and not reason:
                reason = self.faults.check(str(p.value), self.now_ns())
            if reason:
                return SetParametersResult(
                    successful=False, reason=f'{p.name}={p.value!r}: {reason}')
        return SetParametersResult(successful=True)

    def _apply_new_parameters(self, params: Sequence[Any]) -> None:
        """Apply accepted changes (frame_id: the fix template is rebuilt)."""
        for p in params:
            if p.name == 'frame_id':
                self.frame_id = p.value
                self.fix_output.templates(self.frame_id)
            if p.name == 'faults':
                self.faults.apply(self.groups)

    def destroy_node(self) -> None:
        """Close the NMEA stream's sockets, then the node."""
        if self.nmea is not None:
            self.nmea.close()
        super().destroy_node()


def main(args: Sequence[str] | None = None) -> int:
    """Run the error node until shutdown; exit 2 on a bad parameter."""
    return run_node(GpsErrorNode, 'gps_error_node', args,
                    lambda node: f'at shutdown: {node.summary()}', HELP)


HELP = help_text(
    'gps_error_node',
    'ground-truth poses in, smartphone-like sensor_msgs/NavSatFix out (the AR '
    'error model of a profile, stepped on the ROS clock).',
    ERROR_NODE_PARAMS,
    help_rows('gps_error_node'),
    'gps_error_node --ros-args -p profile:=DS5 -p datum:="[40.75, -73.99, 0.0]" '
    '-p seed:=42 -r pose:=/ped1/pose -r fix:=/ped1/fix')


if __name__ == '__main__':
    raise SystemExit(main())

"""
The error node's fixes out: serialized NavSatFix per agent, and NO_FIX.

A fix with a position goes out with its group's covariance (with
``covariance_mode`` conditional or reported, or a zone map: its own;
reported: ``COVARIANCE_TYPE_APPROXIMATED``, a stated radius read as a circle). A step in an
outage (profile ``availability``) goes out, per parameter ``outage_output``,
as a NavSatFix with ``STATUS_NO_FIX``, latitude, longitude and altitude NaN
and covariance ``COVARIANCE_TYPE_UNKNOWN`` (the message's own convention for
"no position"; robot_localization's navsat_transform drops such fixes), or
not at all (``silent``). A non-finite position where a fix was due is never
published: it is counted and logged as an error.
"""

from collections.abc import Mapping, Sequence
import time
from typing import Any

import numpy as np
from sensor_msgs.msg import NavSatFix, NavSatStatus

from gps_error_ros.model.state import BoolArray, FloatArray, IntArray
from gps_error_ros.ros import cdr, conversions, nmea_stream
from gps_error_ros.ros.parameters import WARN_PERIOD_S
from gps_error_ros.ros.rclpy_adapter import publish_raw
from gps_error_ros.sim.engine_types import FixBatch

# A crowd's best-effort fixes go out in bursts this size, this far apart: Fast
# DDS's shared-memory queue of a subscribing process holds 512 messages, and
# an unspaced burst of 1,000 lost about 1 % of them.
FIX_BURST = 100
FIX_BURST_PAUSE_S = 0.001
NO_COVARIANCE = [0.0] * 9


def send_paced(handles: Sequence[Any], raws: Sequence[bytes], burst: int | None = None) -> None:
    """Publish ``raws[i]`` on ``handles[i]``, ``burst`` at a time ``FIX_BURST_PAUSE_S`` apart."""
    burst = burst or max(len(raws), 1)
    for start in range(0, len(raws), burst):
        if start:
            time.sleep(FIX_BURST_PAUSE_S)
        for handle, raw in zip(handles[start:start + burst], raws[start:start + burst]):
            publish_raw(handle, raw)


class FixOutput:
    """Publish the engine's fix batches on the node's per-agent publishers."""

    def __init__(self, node: Any, outage_output: str, best_effort: bool,
                 covariance_mode: str = 'stationary', per_fix: bool = False,
                 about_truth: bool = True) -> None:
        self.node = node
        self.about_truth = about_truth      # vel: its covariance about the truth (with the bias)
        self.outage_output = outage_output
        self.mode = covariance_mode         # conditional, reported: a covariance per fix
        self.per_fix = covariance_mode != 'stationary' or per_fix   # zones: the zone's
        self.burst = FIX_BURST if best_effort else None
        self.refused = 0            # non-finite positions not published
        self.fixes = 0              # NavSatFix messages published with a position
        self.no_fix = 0             # NO_FIX messages published
        self.poses = 0              # PoseWithCovarianceStamped messages published
        self.fix_templates: list[cdr.FixTemplate] = []
        self.no_fix_template: cdr.FixTemplate | None = None

    def templates(self, frame_id: str) -> None:
        """Build the serialized messages again (at start, and for a new frame_id)."""
        self.frame_id = frame_id
        self.fix_templates = [
            cdr.FixTemplate(frame_id, group.covariance, self._cov_type(group),
                            NavSatStatus.STATUS_FIX, NavSatStatus.SERVICE_GPS)
            for group in self.node.groups]
        self.no_fix_template = cdr.FixTemplate(
            frame_id, NO_COVARIANCE, NavSatFix.COVARIANCE_TYPE_UNKNOWN,
            NavSatStatus.STATUS_NO_FIX, NavSatStatus.SERVICE_GPS)

    def _cov_type(self, group: Any) -> int:
        return {'conditional': NavSatFix.COVARIANCE_TYPE_KNOWN,
                'reported': NavSatFix.COVARIANCE_TYPE_APPROXIMATED}.get(
                    self.mode, group.covariance_type)

    def _covs(self, g: int, fix: FixBatch,
              rows: IntArray | BoolArray | slice) -> FloatArray | None:
        """Return the per-fix ENU covariances (m, 9) of ``rows``, or None (the group's)."""
        if not (self.per_fix or fix.cov_per_fix) or fix.cov is None:
            return None
        vertical = self.node.groups[g].covariance[8]
        return conversions.enu_covariances(fix.cov[rows], vertical)

    @staticmethod
    def _has_fix(fix: FixBatch) -> BoolArray:
        """Return the rows with a fix due (False: an outage)."""
        return np.ones(fix.agents.size, dtype=bool) if fix.fix is None else fix.fix

    def _split(self, fix: FixBatch) -> tuple[BoolArray, BoolArray]:
        """Return (rows to publish with a position, rows without a fix)."""
        has = self._has_fix(fix)
        finite = np.isfinite(fix.lat) & np.isfinite(fix.lon) & np.isfinite(fix.alt)
        bad = has & ~finite
        if bad.any():
            self.refused += int(bad.sum())
            self.node.get_logger().error('refused to publish a non-finite fix',
                                         throttle_duration_sec=WARN_PERIOD_S)
        none = ~has if self.outage_output == 'no_fix' else np.zeros_like(has)
        return has & finite, none

    def publish(self, g: int, fixes: Sequence[FixBatch]) -> None:
        """Publish the fix batches of profile group ``g`` (and their velocities)."""
        node = self.node
        members = node.groups[g].members
        for fix in fixes:
            good, none = self._split(fix)
            self.fixes += int(good.sum())
            if fix.velocity is not None:
                self._velocities(g, fix, good)
            if node.pose_frame_id:
                self._poses(g, fix, good)
            if node.nmea is not None:
                self._nmea(g, fix, good, ~self._has_fix(fix))
            if node.polled:
                raws = self.fix_templates[g].render(
                    fix.stamp_ns, fix.lat[good], fix.lon[good], fix.alt[good],
                    self._covs(g, fix, good))
                handles = [node.pub_handles[i] for i in members[fix.agents[good]]]
                if none.any() and self.no_fix_template is not None:
                    n = int(none.sum())
                    nan = np.full(n, np.nan)
                    raws += self.no_fix_template.render(fix.stamp_ns, nan, nan, nan)
                    handles += [node.pub_handles[i] for i in members[fix.agents[none]]]
                    self.no_fix += n
                self._send(handles, raws)
                continue
            group = node.groups[g]
            covs = self._covs(g, fix, slice(None))
            for row in np.flatnonzero(good | none):
                pub = node.pubs[members[fix.agents[row]]]
                if good[row]:
                    pub.publish(conversions.make_fix(
                        fix.stamp_ns, self.frame_id, fix.lat[row], fix.lon[row], fix.alt[row],
                        group.covariance if covs is None else covs[row].tolist(),
                        self._cov_type(group)))
                else:
                    pub.publish(conversions.make_no_fix(fix.stamp_ns, self.frame_id))
                    self.no_fix += 1

    def _velocities(self, g: int, fix: FixBatch, good: BoolArray) -> None:
        """Publish ``vel`` for the rows with a fix and a velocity."""
        if fix.velocity is None or fix.velocity_sd is None:
            return
        node = self.node
        members = node.groups[g].members
        rows = np.flatnonzero(good & np.isfinite(fix.velocity).all(axis=1))
        mean = fix.velocity_mean if self.about_truth else None
        for row in rows:
            pub = node.vel_pubs[members[fix.agents[row]]]
            if pub is not None:
                pub.publish(conversions.make_twist(
                    fix.stamp_ns, self.frame_id, fix.velocity[row, 0], fix.velocity[row, 1],
                    float(fix.velocity_sd[row]) ** 2, None if mean is None else mean[row]))

    def _poses(self, g: int, fix: FixBatch, good: BoolArray) -> None:
        """Publish ``fix_pose``: the rows with a fix, in the map frame about the datum."""
        node = self.node
        rows = np.flatnonzero(good)
        if not rows.size:
            return
        members = node.groups[g].members
        east, north, up = node.frame.to_enu(fix.lat[rows], fix.lon[rows], fix.alt[rows])
        covs = self._covs(g, fix, rows)
        for j, row in enumerate(rows):
            pub = node.pose_pubs[members[fix.agents[row]]]
            if pub is not None:
                pub.publish(conversions.make_pose(
                    fix.stamp_ns, node.pose_frame_id, east[j], north[j], up[j],
                    node.groups[g].covariance if covs is None else covs[j]))
        self.poses += int(rows.size)

    def _nmea(self, g: int, fix: FixBatch, good: BoolArray, none: BoolArray) -> None:
        """Stream the rows as NMEA: a fix for ``good``, quality 0 for ``none``."""
        node = self.node
        group = node.groups[g]
        c = group.covariance            # ENU row-major: north/east from it
        stationary = [[c[4], c[3]], [c[1], c[0]]]
        per_fix = fix.cov is not None and (self.per_fix or fix.cov_per_fix)
        for row in np.flatnonzero(good | none):
            cov = fix.cov[row].tolist() if per_fix and fix.cov is not None else stationary
            vel = None if fix.velocity is None else fix.velocity[row]
            node.nmea.send(int(group.members[fix.agents[row]]), nmea_stream.epoch_bytes(
                fix.stamp_ns, float(fix.lat[row]), float(fix.lon[row]), float(fix.alt[row]),
                bool(good[row]), cov, c[8], vel))

    def _send(self, handles: Sequence[Any], raws: Sequence[bytes]) -> None:
        send_paced(handles, raws, self.burst)


def profile_carries(profile: Any) -> str:
    """Return what a profile carries beside its AR process, in words, for the start-up line."""
    parts = [f'name {profile.name}']
    if profile.effects.names:
        parts.append('effects ' + ', '.join(profile.effects.names))
    parts += [section for section in ('population', 'availability', 'velocity',
                                      'reported_accuracy')
              if getattr(profile, section) is not None]
    failures = profile.gross_failures
    parts.append('no gross failures' if failures is None else
                 f'gross failures at {failures.rate:.3g} per fix')
    return '; '.join(parts)


def start_summary(groups: Sequence[Any], cfg: Mapping[str, Any], who: str, polled: bool,
                  seed: int) -> str:
    """
    Return the node's start-up line: what serves each group, its error's size, the zones.

    With a zone map, the profile named is the one that serves outside the
    zones (the map's ``default_profile`` when it has one), and each zone is
    listed with its own profile. The size is the root mean square error about
    the truth (``covariance_about`` truth) or the SD about the mean.
    """
    zmap = groups[0].engine.zone_map
    what = 'rms error about the truth' if cfg['covariance_about'] == 'truth' else \
        'stationary sd about the mean'
    parts = []
    for group in groups:
        sd = group.engine.model.stationary_sd
        agents = f' ({group.members.size} agents)' if polled else ''
        name = group.profile
        if zmap is not None:
            name = (f'{zmap.default.name} (the map\'s default_profile)'
                    if zmap.default is not None else name) + ' outside the zones'
        carries = f' ({group.carries})' if group.carries else ''
        parts.append(f'profile {name}{agents}: {what} north {sd[0]:.2f} m, east {sd[1]:.2f} m'
                     f'{carries}')
    zones = '' if zmap is None else (
        f'; zones {cfg["zones"]} ({len(zmap)}: ' + ', '.join(
            f'{z} profile {p.name}' for z, p in zip(zmap.names, zmap.profiles)) + ')')
    return f'{"; ".join(parts)}{zones}; {who}; fixes at {cfg["rate"]} Hz, seed {seed}'

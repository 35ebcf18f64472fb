"""
``gps_calibration_node``: fit a profile from live or replayed topics.

Subscribes to measured fixes (``fix``) and ground truth (``pose``, ``odom``
or ``fix_truth`` by ``input_type``), keeps everything it receives, and on the
``~/calibrate`` service (``std_srvs/Trigger``) and at shutdown (Ctrl-C,
SIGTERM) pairs, fits and writes the profile. The raw data are written beside
the profile at every fit and at shutdown, so nothing received is lost even
when the fit is refused.
"""

from collections.abc import Sequence
import csv
from pathlib import Path
from typing import Any

from geometry_msgs.msg import PoseStamped
import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import NavSatFix
from std_srvs.srv import Trigger

from gps_error_ros.fit import calibration
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.model.profiles import write_profile
from gps_error_ros.ros import conversions
from gps_error_ros.ros.diagnostics import DiagnosticsPublisher, OK, Report, WARN
from gps_error_ros.ros.lifecycle import run_node
from gps_error_ros.ros.parameters import (
    CALIBRATION_NODE_PARAMS, ConfigError, datum_frame, declare, WARN_PERIOD_S)
from gps_error_ros.ros.parameter_docs import help_text
from gps_error_ros.ros.rclpy_adapter import take_message
from gps_error_ros.ros.topics import CALIBRATION_INPUT_QOS, help_rows
from gps_error_ros.traces.pairing import pair, PairingError
from gps_error_ros.traces.trace_io import Trace, write_trace_csv
from gps_error_ros.traces.validity import fix_problem, STATUS_NO_FIX


class GpsCalibrationNode(Node):
    """The calibration node (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('gps_calibration_node', **kwargs,
                         automatically_declare_parameters_from_overrides=True)
        cfg = declare(self, CALIBRATION_NODE_PARAMS)
        self.cfg = cfg
        self.output = Path(cfg['output'])
        if not self.output.parent.exists():
            raise ConfigError(f'parameter \'output\': invalid value '
                              f'{cfg["output"]!r}: directory '
                              f'{self.output.parent} does not exist')
        self.frame: LocalTangentFrame | None = None
        if cfg['input_type'] != 'navsatfix':
            self.frame = datum_frame(cfg['datum'], cfg['input_type'])
        self.fixes: list[tuple[float, float, float, int]] = []      # (t, lat, lon, status)
        self.truth: list[tuple[float, float, float]] = []      # (t, lat, lon)
        self.skipped = {'no_fix': 0, 'invalid': 0, 'out_of_order': 0}
        self.truth_dropped = 0
        self.last_fit: tuple[bool, str] | None = None   # (success, message) of the latest fit
        topic, msg_type = conversions.TRUTH_INPUTS[cfg['input_type']]
        qos = CALIBRATION_INPUT_QOS[cfg['input_reliability']]
        self.inputs = [self.create_subscription(NavSatFix, 'fix', self._on_fix, qos),
                       self.create_subscription(msg_type, topic, self._on_truth, qos)]
        self.create_service(Trigger, '~/calibrate', self._on_calibrate)
        self.diagnostics = DiagnosticsPublisher(self, 'calibration', self._report)
        self.get_logger().info(
            f'calibrating from {self.resolve_topic_name("fix")} against '
            f'{self.resolve_topic_name(topic)}; output {self.output}')

    # --- inputs ----------------------------------------------------------

    def _on_fix(self, msg: NavSatFix) -> None:
        t = conversions.stamp_ns(msg.header.stamp) / 1e9
        problem = fix_problem(msg.status.status, msg.latitude, msg.longitude)
        if problem is not None:
            kind = 'no_fix' if msg.status.status == STATUS_NO_FIX else 'invalid'
            self.skipped[kind] += 1
            if kind != 'no_fix':
                self.get_logger().warning(f'skipped a fix: {problem}',
                                          throttle_duration_sec=WARN_PERIOD_S)
            return
        if self.fixes and t <= self.fixes[-1][0]:
            self.skipped['out_of_order'] += 1
            self.get_logger().warning(
                'skipped a fix stamped at or before the previous one',
                throttle_duration_sec=WARN_PERIOD_S)
            return
        self.fixes.append((t, msg.latitude, msg.longitude, msg.status.status))

    def _on_truth(self, msg: Any) -> None:
        t = conversions.stamp_ns(msg.header.stamp) / 1e9
        try:
            if self.frame is None:
                lat, lon, _ = conversions.navsatfix_position(msg)
            else:
                pose = msg.pose if isinstance(msg, PoseStamped) else msg.pose.pose
                e, n, u = conversions.pose_position(pose)
                lat, lon, _ = self.frame.to_geodetic(e, n, u)
        except ValueError as exc:
            self.truth_dropped += 1
            self.get_logger().warning(f'dropped a truth message: {exc}',
                                      throttle_duration_sec=WARN_PERIOD_S)
            return
        if self.truth and t <= self.truth[-1][0]:
            self.truth_dropped += 1
            self.get_logger().warning(
                'dropped a truth message stamped at or before the previous one',
                throttle_duration_sec=WARN_PERIOD_S)
            return
        self.truth.append((t, lat, lon))

    def take_pending(self) -> int:
        """
        Take every message already in the inputs' queues; return how many.

        The executor takes one message per input per pass, so at a fit or at
        shutdown the queue of a busier input (two truth messages per fix, or
        a burst on a loaded machine) can still hold part of what reached the
        node. A fit takes it first, so that it sees and keeps all of it.
        """
        taken = 0
        for sub in self.inputs:
            while True:
                try:
                    got = take_message(sub)
                except RuntimeError as exc:     # rclpy could not convert one
                    self.get_logger().warning(f'stopped taking the queue of '
                                              f'{sub.topic_name}: {exc}')
                    break
                if got is None:
                    break
                sub.callback(got)
                taken += 1
        return taken

    # --- fitting ---------------------------------------------------------

    def _on_calibrate(self, request: Any, response: Any) -> Any:
        response.success, response.message = self.calibrate()
        return response

    def _report(self) -> Report:
        """Return the /diagnostics status: what was received, the latest fit."""
        values: dict[str, Any] = {
            'fixes received': len(self.fixes), 'truth received': len(self.truth),
            'truth dropped': self.truth_dropped, 'output': str(self.output)}
        values.update({f'fixes skipped ({k.replace("_", " ")})': v
                       for k, v in self.skipped.items()})
        if self.last_fit is not None:
            values['latest fit'] = ('wrote the profile: ' if self.last_fit[0]
                                    else 'refused: ') + self.last_fit[1]
        if not self.fixes or not self.truth:
            return Report(WARN, f'waiting for data: {len(self.fixes)} fixes, '
                          f'{len(self.truth)} truth messages', values)
        message = f'{len(self.fixes)} fixes and {len(self.truth)} truth messages held'
        if self.last_fit is not None and not self.last_fit[0]:
            return Report(WARN, message + '; the latest fit was refused', values)
        return Report(OK, message, values)

    def _sibling(self, suffix: str) -> Path:
        return self.output.with_name(self.output.stem + suffix)

    def save_raw(self) -> None:
        """Write everything received: <stem>.fixes.csv and <stem>.truth.csv."""
        with open(self._sibling('.fixes.csv'), 'w', newline='') as f:
            w = csv.writer(f)
            w.writerow(['t', 'lat', 'lon', 'status'])
            w.writerows((repr(t), repr(a), repr(o), s) for t, a, o, s in self.fixes)
        with open(self._sibling('.truth.csv'), 'w', newline='') as f:
            w = csv.writer(f)
            w.writerow(['t', 'lat', 'lon'])
            w.writerows((repr(t), repr(a), repr(o)) for t, a, o in self.truth)

    def calibrate(self) -> tuple[bool, str]:
        """Pair, fit and write all received; return (success, message), kept for /diagnostics."""
        self.take_pending()
        self.last_fit = self._calibrate()
        return self.last_fit

    def _calibrate(self) -> tuple[bool, str]:
        """
        Pair, fit and write; return (success, message).

        The three CSVs are written whatever happens (the paired trace empty,
        header only, when nothing could be paired), so nothing received is
        lost and the files a user looks for are always there.
        """
        self.save_raw()
        empty = np.zeros(0)
        self._write_trace(Trace('received topics', empty, empty, empty, empty, empty))
        skipped = ', '.join(f'{v} {k.replace("_", " ")}'
                            for k, v in self.skipped.items() if v)
        skipped = f'; skipped fixes: {skipped}' if skipped else ''
        if not self.fixes or len(self.truth) < 2:
            return False, (f'not enough data: {len(self.fixes)} fixes, '
                           f'{len(self.truth)} truth messages{skipped}')
        fx = np.array([f[:3] for f in self.fixes])
        tr = np.array(self.truth)
        gap = self.cfg['max_truth_gap'] or None
        try:
            trace, stats = pair(fx[:, 0], fx[:, 1], fx[:, 2], tr[:, 0], tr[:, 1],
                                tr[:, 2], gap, 'received topics')
        except PairingError as exc:
            return False, f'{exc}{skipped}'
        self._write_trace(trace)
        try:
            result = calibration.calibrate(
                trace, order=self.cfg['order'] or None,
                max_order=self.cfg['max_order'])
        except calibration.CalibrationError as exc:
            return False, f'{stats.describe()}{skipped}; fit refused: {exc}'
        profile = result.profile_dict(
            self.cfg['name'] or self.output.stem,
            description='fitted by gps_calibration_node',
            source=f'gps_calibration_node, {stats.paired} paired fixes')
        write_profile(self.output, profile)
        parts = []
        for ax, fit in (('north', result.north), ('east', result.east)):
            p = fit.params
            parts.append(f'{ax} AR({p.order}) delta={p.delta:.4f} '
                         f'phi={[round(v, 4) for v in p.phi]} '
                         f'sigma_w={p.sigma_w:.4f}')
        note = calibration.damage_note(result.grid, stats.fixes_in, stats.in_truth_gap)
        if note:
            self.get_logger().warning(note)
            note = f'; WARNING: {note}'
        return True, (f'wrote {self.output}: {result.grid.n} samples in '
                      f'{len(result.grid.segments)} segment(s); '
                      + '; '.join(parts) + f' ({stats.describe()}{skipped}){note or ""}')

    def _write_trace(self, trace: Trace) -> None:
        write_trace_csv(trace, self._sibling('.trace.csv'))


def _fit_at_shutdown(node: GpsCalibrationNode) -> str:
    ok, message = node.calibrate()
    return f'at shutdown: {message}' if ok else f'at shutdown (no profile): {message}'


def main(args: Sequence[str] | None = None) -> int:
    """Run the calibration node; fit and write at shutdown."""
    return run_node(GpsCalibrationNode, 'gps_calibration_node', args,
                    _fit_at_shutdown, HELP)


HELP = help_text(
    'gps_calibration_node',
    'measured fixes and ground truth in; on ~/calibrate and at shutdown, a '
    'profile fitted to their errors (and the raw data as CSV) out.',
    CALIBRATION_NODE_PARAMS,
    help_rows('gps_calibration_node'),
    'gps_calibration_node --ros-args -p input_type:=navsatfix '
    '-p output:=my_phone.yaml -r fix:=/phone/fix -r fix_truth:=/span/fix')


if __name__ == '__main__':
    raise SystemExit(main())

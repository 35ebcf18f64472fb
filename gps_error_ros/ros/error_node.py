"""
``gps_error_node``: ground-truth poses in, smartphone-like NavSatFix out.

Subscribes to the truth (``pose``, ``odom`` or ``fix_truth`` by
``input_type``), steps the profile's AR error model on the ROS clock and
publishes ``sensor_msgs/NavSatFix`` on ``fix``. All arithmetic lives in
:mod:`gps_error_ros.engine`; this module converts messages and parameters.
"""

import math
import secrets

from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import (HistoryPolicy, QoSProfile, ReliabilityPolicy)
from rcl_interfaces.msg import SetParametersResult
from sensor_msgs.msg import NavSatFix

from ..engine import FixEngine
from ..geodesy import GeodesyError, LocalTangentFrame
from ..profiles import load_profile, ProfileError
from ..streams import agent_key
from . import conversions
from .parameters import ConfigError, declare, ERROR_NODE_PARAMS, spec_by_name

INPUT_TOPICS = {
    'pose': ('pose', PoseStamped),
    'odometry': ('odom', Odometry),
    'navsatfix': ('fix_truth', NavSatFix),
}
WARN_PERIOD_S = 5.0
# Sensor-data QoS (best effort, volatile) with a deeper history than the
# stock profile's 5, so a burst of truth messages is buffered, not dropped.
TRUTH_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                       reliability=ReliabilityPolicy.BEST_EFFORT)


class GpsErrorNode(Node):
    """The single-agent error node (see the module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('gps_error_node', **kwargs)
        cfg = declare(self, ERROR_NODE_PARAMS)
        self._specs = spec_by_name(ERROR_NODE_PARAMS)
        self.frame_id = cfg['frame_id']
        try:
            self.profile = load_profile(cfg['profile'])
            model = self.profile.model()
        except ProfileError as exc:
            raise ConfigError(f'parameter \'profile\' ({cfg["profile"]!r}): '
                              f'{exc}') from None
        self.input_type = cfg['input_type']
        self.frame = None
        if self.input_type != 'navsatfix':
            self.frame = self._datum_frame(cfg['datum'])
        seed = cfg['seed']
        if seed < 0:
            seed = secrets.randbits(63)
            self.get_logger().info(f'no seed given: using seed {seed}')
        self.seed = seed
        self.engine = FixEngine(
            model, [agent_key(seed, '')], rate=cfg['rate'],
            model_rate=self.profile.rate_hz, max_pose_age=cfg['max_pose_age'])
        self.covariance, self.covariance_type = conversions.enu_covariance(
            model.stationary_cov, self.profile.vertical_variance(model))

        topic, msg_type = INPUT_TOPICS[self.input_type]
        self.create_subscription(msg_type, topic, self._on_truth, TRUTH_QOS)
        self.pub = self.create_publisher(NavSatFix, 'fix', QoSProfile(depth=10))
        self.timer = self.create_timer(1.0 / cfg['rate'], self._on_timer)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        sd = model.stationary_sd
        self.get_logger().info(
            f'profile {self.profile.name}: stationary sd north {sd[0]:.2f} m, '
            f'east {sd[1]:.2f} m; input {self.input_type} on '
            f'{self.resolve_topic_name(topic)}; fixes on '
            f'{self.resolve_topic_name("fix")} at {cfg["rate"]} Hz')

    def _datum_frame(self, datum):
        if not datum:
            raise ConfigError(
                f'parameter \'datum\' is required for input_type '
                f'{self.input_type!r}: expected [lat_deg, lon_deg, alt_m] of '
                f'the map frame origin')
        if len(datum) not in (2, 3):
            raise ConfigError(f'parameter \'datum\': invalid value {datum!r}: '
                              f'expected [lat_deg, lon_deg] or '
                              f'[lat_deg, lon_deg, alt_m]')
        try:
            return LocalTangentFrame(*datum)
        except GeodesyError as exc:
            raise ConfigError(f'parameter \'datum\': invalid value {datum!r}: '
                              f'{exc}') from None

    # --- callbacks -------------------------------------------------------

    def _now_ns(self):
        return self.get_clock().now().nanoseconds

    def _on_truth(self, msg):
        try:
            if self.input_type == 'navsatfix':
                lat, lon, alt = conversions.navsatfix_position(msg)
            else:
                pose = msg.pose if self.input_type == 'pose' else msg.pose.pose
                east, north, up = conversions.pose_position(pose)
                lat, lon, alt = self.frame.to_geodetic(east, north, up)
                if not all(map(math.isfinite, (lat, lon, alt))):
                    raise ValueError('position outside the datum frame\'s range')
        except ValueError as exc:
            self.get_logger().warning(f'dropped a truth message: {exc}',
                                      throttle_duration_sec=WARN_PERIOD_S)
            return
        stamp = conversions.stamp_ns(msg.header.stamp) or self._now_ns()
        if not self.engine.add_truth(0, stamp, lat, lon, alt):
            self.get_logger().warning(
                'dropped a truth message stamped at or before the newest one '
                '(out of order or duplicate)', throttle_duration_sec=WARN_PERIOD_S)
            return
        self._publish(self.engine.resolve(self._now_ns()))

    def _on_timer(self):
        self._publish(self.engine.on_clock(self._now_ns()))

    def _publish(self, fixes):
        for fix in fixes:
            for lat, lon, alt in zip(fix.lat, fix.lon, fix.alt):
                if not np.isfinite([lat, lon, alt]).all():
                    self.get_logger().error('refused to publish a non-finite fix',
                                            throttle_duration_sec=WARN_PERIOD_S)
                    continue
                self.pub.publish(conversions.make_fix(
                    fix.stamp_ns, self.frame_id, lat, lon, alt,
                    self.covariance, self.covariance_type))

    def _on_set_parameters(self, params):
        for p in params:
            spec = self._specs.get(p.name)
            if spec is None:
                continue
            if spec.read_only:
                return SetParametersResult(
                    successful=False, reason=f'{p.name} is read-only')
            reason = spec.check(p.value)
            if reason:
                return SetParametersResult(
                    successful=False, reason=f'{p.name}={p.value!r}: {reason}')
        for p in params:
            if p.name == 'frame_id' and p.type_ == Parameter.Type.STRING:
                self.frame_id = p.value
        return SetParametersResult(successful=True)


def main(args=None):
    """Run the error node until shutdown; exit 2 on a bad parameter."""
    rclpy.init(args=args)
    node = None
    try:
        node = GpsErrorNode()
        rclpy.spin(node)
    except ConfigError as exc:
        rclpy.logging.get_logger('gps_error_node').fatal(str(exc))
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())

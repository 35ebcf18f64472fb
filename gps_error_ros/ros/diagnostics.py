"""
``/diagnostics`` for both nodes: one DiagnosticStatus per second of wall time.

What ``rqt_robot_monitor`` and Foxglove's diagnostics panels read
(``diagnostic_msgs/DiagnosticArray``). The period is wall time (a steady
clock), not the ROS clock, so that the status keeps coming when a simulator
pauses ``/clock``: a stalled clock is exactly when an operator looks.

Each node gives a ``report()`` returning a :class:`Report`: level, one-line
message and key/value pairs. The status name is ``<node name>: <what>``
and the hardware id the node's fully qualified name, so that several error
nodes (shards of a crowd) show as separate rows.
"""

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from gps_error_ros.ros.topics import DIAGNOSTICS_QOS, DIAGNOSTICS_TOPIC

OK = DiagnosticStatus.OK
WARN = DiagnosticStatus.WARN
ERROR = DiagnosticStatus.ERROR
PERIOD_S = 1.0


@dataclass
class Report:
    """What one status message says."""

    level: bytes       # OK, WARN or ERROR (DiagnosticStatus's byte constants)
    message: str
    values: dict[str, Any] = field(default_factory=dict)


def _text(value: object) -> str:
    if isinstance(value, float):
        return f'{value:.6g}'
    return str(value)


class DiagnosticsPublisher:
    """
    Publish ``report()`` on ``/diagnostics`` every :data:`PERIOD_S` wall seconds.

    A report that raises is published as an ERROR status naming the
    exception (the node keeps running: the diagnostics must not be what
    brings it down).
    """

    def __init__(self, node: Node, what: str, report: Callable[[], Report],
                 period_s: float = PERIOD_S) -> None:
        self.node = node
        self.name = f'{node.get_name()}: {what}'
        self.hardware_id = node.get_fully_qualified_name()
        self.report = report
        self.pub = node.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC,
                                         DIAGNOSTICS_QOS)
        self.timer = node.create_timer(period_s, self.publish,
                                       clock=Clock(clock_type=ClockType.STEADY_TIME))

    def publish(self) -> None:
        """Build the status now and publish it."""
        try:
            rep = self.report()
        except Exception as exc:   # noqa: BLE001 - reported, never raised
            rep = Report(ERROR, f'diagnostics failed: {type(exc).__name__}: {exc}')
        status = DiagnosticStatus(
            level=rep.level, name=self.name, message=rep.message,
            hardware_id=self.hardware_id,
            values=[KeyValue(key=str(k), value=_text(v)) for k, v in rep.values.items()])
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.node.get_clock().now().to_msg()
        self.pub.publish(msg)


class Counters:
    """Totals at the previous report, to say what changed since."""

    def __init__(self) -> None:
        self.previous: dict[str, float] = {}

    def delta(self, key: str, total: float) -> float:
        """Return ``total`` minus its value at the previous call for ``key``."""
        change = total - self.previous.get(key, 0)
        self.previous[key] = total
        return change

"""The error node's faults on demand: ``fault_schedule`` at start, ``faults`` at run time."""

from collections.abc import Sequence
from typing import Any

from gps_error_ros.ros.parameters import ConfigError
from gps_error_ros.sim.engine import NS
from gps_error_ros.sim.faults import Fault, FaultError, faults_from_yaml, load_schedule


class NodeFaults:
    """
    The faults a node lays over its fixes (:mod:`gps_error_ros.sim.faults`).

    Read from the parameters ``fault_schedule`` (a file) and ``faults`` (YAML
    text; set at start, entries without ``at`` start with the streams; set at
    run time, from the next step). Each profile group's engine holds an
    overlay of its own; :meth:`apply` adds accepted faults to all of them.
    """

    def __init__(self, node: Any, path: str, given: str) -> None:
        self.node = node
        self.faults: list[Fault] = []
        self._pending: list[Fault] = []
        try:
            if path.strip():
                self.faults = load_schedule(path)
                node.get_logger().info(f'fault schedule {path}: {len(self.faults)} fault(s)')
        except FaultError as exc:
            raise ConfigError(f'parameter \'fault_schedule\': {exc}') from None
        try:
            if given.strip():
                extra = faults_from_yaml(given, 'faults', now_s=0.0)
                self.faults += extra
                node.get_logger().info(f'faults given at start: {len(extra)} fault(s)')
        except FaultError as exc:
            raise ConfigError(f'parameter \'faults\': {exc}') from None

    def check(self, text: str, now_ns: int) -> str | None:
        """Parse a runtime value of ``faults``; return why it is refused, or None."""
        if not text.strip():
            return None
        try:
            self._pending = faults_from_yaml(text, 'faults', now_s=now_ns / NS)
        except FaultError as exc:
            return str(exc)
        return None

    def apply(self, groups: Sequence[Any]) -> None:
        """Add the faults :meth:`check` accepted to every group's engine, and log them."""
        if not self._pending:
            return
        self.faults.extend(self._pending)
        for group in groups:
            if group.engine.faults is not None:
                group.engine.faults.add(self._pending)
        self.node.get_logger().info('faults added: ' + '; '.join(
            f'{f.kind} on {f.agent or "every agent"} from {f.at_ns / NS:.3f} s '
            f'for {f.duration_ns / NS:g} s' for f in self._pending))
        self._pending = []

    @staticmethod
    def touched(groups: Sequence[Any]) -> int:
        """Return the fixes the faults touched so far, over every group."""
        return sum(sum(g.engine.faults.applied.values()) for g in groups
                   if g.engine.faults is not None)

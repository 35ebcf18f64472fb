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

    def __init__(self, node: Any, path: str, given: str, period_ns: int = int(NS)) -> None:
        self.node = node
        self.period_ns = period_ns
        self.faults: list[Fault] = []
        self._pending: list[Fault] = []
        self._now_ns = 0
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
        unknown = self._unknown(self.faults)
        if unknown:
            node.get_logger().warning(f'faults name agents this node does not serve: '
                                      f'{unknown} ({self._served()}); they do nothing here')

    def _served(self) -> str:
        """Return the node's agents, as a message names them."""
        names = self.node.agents
        if names == ['']:
            return 'a single-agent node: leave agent out'
        return 'its agents: ' + ', '.join(names)

    def _unknown(self, faults: Sequence[Fault]) -> list[str]:
        """Return the agent names of ``faults`` that the node does not serve."""
        served = self.node.agents
        if any(a is None for a in served):      # agents that come and go: any may come
            return []
        return sorted({f.agent for f in faults if f.agent is not None and f.agent not in served})

    def check(self, text: str, now_ns: int) -> str | None:
        """Parse a runtime value of ``faults``; return why it is refused, or None."""
        if not text.strip():
            return None
        try:
            # without at: from the first output step after the clock (the step at the
            # clock's reading may have gone out already)
            first = (now_ns // self.period_ns + 1) * self.period_ns
            pending = faults_from_yaml(text, 'faults', now_s=first / NS)
        except FaultError as exc:
            return str(exc)
        unknown = self._unknown(pending)
        if unknown:
            return f'faults: agent(s) {unknown} not served by this node ({self._served()})'
        over = [f for f in pending if f.end_ns <= now_ns]
        if over:
            return (f'faults: {over[0].kind} from {over[0].at_ns / NS:g} s for '
                    f'{over[0].duration_ns / NS:g} s ends before the node\'s clock '
                    f'({now_ns / NS:.3f} s): nothing left to fault; give a later at, or none '
                    f'(from the next step)')
        self._pending = pending
        self._now_ns = now_ns
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
        late = [f for f in self._pending if f.at_ns < self._now_ns]
        if late:
            self.node.get_logger().warning(
                f'{len(late)} fault(s) began before the node\'s clock '
                f'({self._now_ns / NS:.3f} s) when set: only the steps from then on, and '
                f'those still waiting for truth, get them')
        self._pending = []

    @staticmethod
    def touched(groups: Sequence[Any]) -> int:
        """Return the fixes the faults touched so far, over every group."""
        return sum(sum(g.engine.faults.applied.values()) for g in groups
                   if g.engine.faults is not None)

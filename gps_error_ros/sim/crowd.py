"""
Errors for a changing crowd of named agents, stepped along a time line.

Network simulators (SUMO, ns-3, OMNeT++) do not run ROS; their trajectories
come as files where agents appear and disappear. :class:`CrowdErrors` gives
each named agent the same errors the error node would publish for it with the
same seed, profile and first clock step: every agent's model starts at the
run's first model step, from its own stream, and advances once per model
step whether or not the agent is present. An agent first seen later is
caught up from the run's start (vectorised), so what it gets does not depend
on when it appeared or who else is present.
"""

from collections.abc import Callable, Sequence
from typing import Any, Generic, TypeVar

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.protocol import ErrorModel, S
from gps_error_ros.model.state import AgentState, BoolArray, FloatArray, IntArray, Numbers
from gps_error_ros.model.stepping import state_at, step as model_step, StepsPerFix
from gps_error_ros.model.zoned import ZoneSetup
from gps_error_ros.model.zones import ZoneMap


#: What :meth:`CrowdErrors._of_rows` gathers: errors or masks.
A = TypeVar('A', FloatArray, BoolArray)


class CrowdErrors(Generic[S]):
    """
    Per-agent AR errors on the model grid, for agents that come and go.

    Parameters
    ----------
    model
        The profile's model (one for the whole crowd).
    seed
        The run's seed (as the node's ``seed`` parameter).
    start_step
        The run's first model step (the node: its first clock step).
    forget_after
        Agents unseen for this many steps are dropped from the state; if they
        come back they are caught up again from the start (same values).
    conditional_cov
        Keep each agent's covariance given the state a step before.
    zoned
        ``(ZoneMap, StepsPerFix)``: the errors follow each agent's zone.

    """

    def __init__(self, model: ErrorModel[S], seed: int, start_step: int,
                 forget_after: int = 600, conditional_cov: bool = False,
                 zoned: ZoneSetup | None = None) -> None:
        self.model = model
        self.seed = seed
        self.start = int(start_step)
        self.step = int(start_step)
        self.forget_after = forget_after
        self.names: list[str] = []
        self.index: dict[str, int] = {}
        self.keys = np.zeros(0, dtype=np.uint64)
        self.state = model.empty_state(0)
        self.last_seen = np.zeros(0, dtype=np.int64)
        #: changes whenever agents are dropped (their rows move): see :meth:`coded_rows`
        self.generation = 0
        self._codes: tuple[Any, int, IntArray] | None = None
        # conditional_cov: each agent's covariance of its current error given
        # the state a step before (covariance_mode conditional)
        self.conditional_cov = conditional_cov
        self.cov_now: FloatArray = np.zeros((0, 2, 2))
        # zoned: (ZoneMap, StepsPerFix) when the errors follow a zone map
        self.zone_map: ZoneMap | None = None
        self.zoned: StepsPerFix[AgentState] | None = None
        if zoned is not None:
            self.zone_map, self.zoned = zoned
        if self.zoned is not None:
            self.zoned.restart(self.start)

    def advance_to(self, step: int) -> None:
        """Advance every known agent to model step ``step`` (never back)."""
        if step < self.step:
            raise ValueError(f'time went backwards: model step {step} after '
                             f'{self.step}')
        while self.step < step:
            self.step += 1
            if self.keys.size:
                cov = model_step(self.model, self.state, self.keys, self.step,
                                 cov=self.conditional_cov)
                if cov is not None:
                    self.cov_now = cov

    def rows(self, names: Sequence[str]) -> IntArray:
        """Return the state rows of ``names`` (valid until the next errors call)."""
        return self._rows(names)

    def coded_rows(self, dictionary: Sequence[str], codes: IntArray) -> IntArray:
        """
        Return the state rows of the agents ``dictionary[codes]``.

        For a table's column of agent names, dictionary-encoded: each name
        of ``dictionary`` is looked up once, not once per row. The rows
        found are kept for the next call with the same ``dictionary``
        object, as long as no agent was dropped.
        """
        cache = self._codes
        if cache is None or cache[0] is not dictionary or cache[1] != self.generation:
            cache = (dictionary, self.generation, np.full(len(dictionary), -1, dtype=np.int64))
            self._codes = cache
        lut = cache[2]
        rows = lut[codes]
        if (rows < 0).any():
            todo = np.unique(codes[rows < 0])
            lut[todo] = self._rows(list(map(dictionary.__getitem__, todo.tolist())))
            rows = lut[codes]
        return rows

    def errors(self, names: Sequence[str], rows: IntArray | None = None) -> FloatArray:
        """Return the named agents' current north/east errors, in metres (``rows``: theirs)."""
        rows = self._rows(names) if rows is None else rows
        self.last_seen[rows] = self.step
        out = self._of_rows(self.model.errors, rows)
        if self.forget_after and self.step % 64 == 0:
            self._forget()
        return out

    def zoned_errors(self, names: Sequence[str], lat: Numbers, lon: Numbers,
                     heading: Numbers | None = None,
                     rows: IntArray | None = None) -> tuple[FloatArray, FloatArray]:
        """
        Return the named agents' errors and covariances in the zones of (lat, lon).

        With a zone map: each agent's error follows the zone its truth is in
        (:mod:`gps_error_ros.model.zoned`); the covariance is the zone's
        (stationary, or conditional with ``conditional_cov``). Without a map
        (a street-frame profile) every agent is in the default zone.
        ``heading``: the direction of travel (street_frame); ``rows``: the
        agents' rows (:meth:`coded_rows`), else looked up by name.
        """
        rows = self._rows(names) if rows is None else rows
        self.last_seen[rows] = self.step
        zones = None if self.zone_map is None else self.zone_map.lookup(lat, lon)
        if self.zoned is None:
            raise ValueError('zoned_errors: the crowd has no zones (expected zoned=...)')
        out = self.zoned.errors(rows, self.keys[rows], self.step, zones, heading)
        if self.forget_after and self.step % 64 == 0:
            self._forget()
        return out

    def covariance(self, names: Sequence[str], rows: IntArray | None = None) -> FloatArray:
        """Return the named agents' predictive covariances now (conditional_cov), (n, 2, 2)."""
        return self.cov_now[self._rows(names) if rows is None else rows]

    def available(self, names: Sequence[str], rows: IntArray | None = None) -> BoolArray:
        """Return which named agents have a fix now (profile availability; else all)."""
        return self._of_rows(self.model.fix_mask, self._rows(names) if rows is None else rows)

    def _of_rows(self, per_agent: Callable[[S], A], rows: IntArray) -> A:
        """
        Return ``per_agent`` (a model's function of a state, agent by agent) for ``rows``.

        When most agents are asked for, it runs on the whole state and is
        indexed: cheaper than taking the rows of every field of the state.
        """
        if 2 * rows.size < self.keys.size:
            return per_agent(self.state.take(rows))
        out = per_agent(self.state)
        every = rows.size == self.keys.size and np.array_equal(rows, np.arange(rows.size))
        return out if every else out[rows]

    def _rows(self, names: Sequence[str]) -> IntArray:
        """Return the state rows of ``names``, adding the agents not yet known."""
        if not self.index.keys() >= set(names):
            self._add([n for n in dict.fromkeys(names) if n not in self.index])
        return np.fromiter(map(self.index.__getitem__, names), dtype=np.int64, count=len(names))

    def _add(self, names: Sequence[str]) -> None:
        keys = np.array([streams.agent_key(self.seed, n) for n in names],
                        dtype=np.uint64)
        state, cov = state_at(self.model, keys, self.start, self.step,
                              cov=self.conditional_cov)
        if cov is not None:
            self.cov_now = np.concatenate([self.cov_now, cov])
        base = len(self.names)
        for i, n in enumerate(names):
            self.index[n] = base + i
        self.names.extend(names)
        self.keys = np.concatenate([self.keys, keys])
        self.state = self.state.joined(state)
        self.last_seen = np.concatenate(
            [self.last_seen, np.full(len(names), self.step, dtype=np.int64)])
        if self.zoned is not None:
            self.zoned.grow(len(names))

    def _forget(self) -> None:
        keep = self.step - self.last_seen <= self.forget_after
        if keep.all():
            return
        self.generation += 1
        self.names = [n for n, k in zip(self.names, keep) if k]
        self.index = {n: i for i, n in enumerate(self.names)}
        self.keys, self.state = self.keys[keep], self.state.take(keep)
        if self.conditional_cov:
            self.cov_now = self.cov_now[keep]
        self.last_seen = self.last_seen[keep]
        if self.zoned is not None:
            self.zoned.keep(keep)

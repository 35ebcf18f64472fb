"""
The fix engine: model steps from the clock, truth history, fixes out.

This is everything the error node computes, without ROS. The node feeds it
truth positions and clock readings and publishes what it returns.

The timing rules (output steps on the clock, the model's own grid, truth
interpolated or held up to ``max_pose_age``, out-of-order and future truth,
motion lag, clock resets, zones, agents that come and go) are in the
documentation: ``docs/timing.md``.
"""

from collections import deque
from typing import Generic

import numpy as np

from gps_error_ros.model.geodesy import offset
from gps_error_ros.model.protocol import ErrorModel, opaque, S
from gps_error_ros.model.reported import reference_cov, ReportedAccuracy
from gps_error_ros.model.state import AgentState, BoolArray, FloatArray, IntArray, Keys, Numbers
from gps_error_ros.model.stepping import state_at, step as model_step, StepsPerFix
from gps_error_ros.model.velocity import Velocity
from gps_error_ros.model.zoned import travel_direction, ZoneSetup
from gps_error_ros.model.zones import ZoneMap
from gps_error_ros.sim.engine_types import EngineStats, FixBatch, PendingStep
from gps_error_ros.sim.faults import FaultOverlay, FixRows
from gps_error_ros.sim.truth_ring import TruthRing
from gps_error_ros.sim.velocity_state import SideStream, VelocityState

NS = 1_000_000_000
FUTURE_TOLERANCE_S = 60.0


class FixEngine(Generic[S]):
    """
    Turn truth samples and clock readings into noisy fixes.

    Parameters
    ----------
    model
        The error process (shared by all agents).
    keys
        One stream key per agent (:func:`streams.agent_key`).
    rate
        Output rate in Hz.
    model_rate
        The model's own rate in Hz (the profile's ``rate_hz``).
    max_pose_age
        Seconds a truth sample may be held past its stamp (see module doc).
    history
        Truth samples kept per agent.
    max_pending
        Output steps that may wait for truth at once; older ones are
        resolved (held or skipped) early when more arrive.
    active
        False: every slot starts free (agents come with :meth:`attach`).
    start_ns
        Clock time of the streams' first step (rounded up to a step); None:
        the first clock reading. Fixed, it makes the fixes independent of
        when the engine saw its first reading (see :meth:`on_clock`).
    velocity
        The profile's velocity section: each fix carries a reported velocity.
    conditional_cov
        Each fix carries the model's covariance of its error given the state
        a step before (else the node states the stationary one).
    zones
        ``(ZoneMap, StepsPerFix)``: the errors follow each fix's zone.
    reported
        The profile's reported_accuracy: each fix carries the radius the
        phone states and the covariance it implies.
    reported_bias
        With ``reported``: the error's mean, added to the stated covariance
        as ``m m^T`` (covariance about the truth).
    faults
        Faults on demand (:mod:`~gps_error_ros.sim.faults`) laid over the
        fixes; the engine's slots are their row ids.

    """

    def __init__(self, model: ErrorModel[S], keys: Keys, rate: float = 1.0,
                 model_rate: float = 1.0, max_pose_age: float = 1.0, history: int = 64,
                 max_pending: int = 1000, active: bool = True, start_ns: int | None = None,
                 velocity: Velocity | None = None, conditional_cov: bool = False,
                 zones: ZoneSetup | None = None,
                 reported: ReportedAccuracy | None = None,
                 reported_bias: Numbers | None = None,
                 faults: FaultOverlay | None = None) -> None:
        if not rate > 0 or not model_rate > 0:
            raise ValueError(f'rates must be > 0, got rate={rate}, '
                             f'model_rate={model_rate}')
        if not max_pose_age >= 0:
            raise ValueError(f'max_pose_age must be >= 0, got {max_pose_age}')
        self.model = model
        self.keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        self.n = self.keys.size
        self.period_ns = int(round(NS / rate))
        self.model_period_ns = int(round(NS / model_rate))
        self.max_pose_age_ns = int(round(max_pose_age * NS))
        self.future_tolerance_ns = int(FUTURE_TOLERANCE_S * NS)
        self.max_gap_ns = max(2 * NS, 2 * self.max_pose_age_ns)
        self.max_pending = max_pending
        # the first step of the streams: fixed (start_ns), or the first clock reading
        self.start_step = None if start_ns is None else -(-int(start_ns) // self.period_ns)
        # a motion lag reports the truth lag_s before each step: keep enough
        # samples to reach back that far at pose rates up to ~64 Hz
        self.lag_ns = int(round(model.lag_s * NS))
        if self.lag_ns:
            history = max(history, int(64 * (1 + model.lag_s)))
        self.truth = TruthRing(self.n, history)
        # per agent: the first step skipped for want of truth since truth was
        # last found late (-1: none)
        self.last_skipped = np.full(self.n, -1, dtype=np.int64)
        # per agent: the newest stamp of truth that was dropped as invalid (-1: none)
        self.last_invalid = np.full(self.n, -1, dtype=np.int64)
        self.active = np.full(self.n, bool(active))
        self.stats = EngineStats()
        self._side_streams(velocity, reported, reported_bias)
        # conditional_cov: each fix carries the model's covariance of its error
        # given the state a step before (None: the node reports the stationary one);
        # a stated radius that follows the predictive scale needs it
        self.conditional_cov = conditional_cov or self.ref_cov is not None
        self.cov_now: FloatArray | None = None
        self.faults = faults
        self._zones(zones)
        self._reset_time()

    def _side_streams(self, velocity: Velocity | None, reported: ReportedAccuracy | None,
                      reported_bias: Numbers | None) -> None:
        """Set up the side streams stepped with the model (velocity error, stated accuracy)."""
        self.side: dict[str, SideStream] = {}
        self.vel = None if velocity is None else VelocityState(velocity, self.n)
        if self.vel is not None:
            self.side['vel'] = self.vel
        self.reported = reported
        self.reported_bias = reported_bias      # about the truth: the mean, added
        self.ref_cov: FloatArray | None = None
        if reported is not None:
            self.side['rep'] = SideStream(reported, self.n)
            if reported.follow != 0.0:      # the radius follows the predictive scale
                self.ref_cov = reference_cov(self.model)

    def _zones(self, zones: ZoneSetup | None) -> None:
        """
        Set up the zones: errors follow each fix's zone.

        A street frame needs each fix's direction of travel: the same path, one zone.
        """
        self.zone_map: ZoneMap | None = None
        self.zoned: StepsPerFix[AgentState] | None = None
        if zones is not None:
            self.zone_map, self.zoned = zones
        if self.zoned is None and self.model.needs_heading:
            self.zoned = StepsPerFix(opaque(self.model), conditional_cov=self.conditional_cov)
        if self.zoned is not None:
            self.zoned.grow(self.n - self.zoned.n)

    def _reset_time(self) -> None:
        self.state: S | None = None
        self.began_ns: int | None = None        # clock time of the streams' first step
        # the model step of the state, and of the streams' first step (0 before it)
        self.model_index = 0
        self.start_index = 0
        self.last_step: int | None = None
        self.last_now: int | None = None
        self.pending: deque[PendingStep] = deque()

    # --- inputs ----------------------------------------------------------

    def add_truth(self, agent: int, stamp_ns: int, lat: float, lon: float, alt: float) -> bool:
        """Store a truth sample; return False if dropped (order, future)."""
        if self.last_now is not None and \
                stamp_ns > self.last_now + self.future_tolerance_ns:
            self.stats.dropped_future += 1
            return False
        if stamp_ns <= self.truth.newest[agent]:
            self.stats.dropped_out_of_order += 1
            return False
        self.truth.push(np.array([agent]), np.array([int(stamp_ns)]),
                        np.array([[lat, lon, alt]]))
        self._note_late(np.array([agent]), np.array([int(stamp_ns)]))
        return True

    def note_invalid(self, agents: Numbers, stamps: Numbers) -> None:
        """
        Note truth of ``agents`` (local indices) stamped ``stamps`` (ns) that was invalid.

        Non-finite positions, a zero quaternion: the caller drops them. The
        steps they would have served are skipped (no fix, no NO_FIX), and
        valid truth after them is not counted as late (``invalid_gaps``).
        """
        agents = np.atleast_1d(np.asarray(agents, dtype=np.int64))
        stamps = np.atleast_1d(np.asarray(stamps, dtype=np.int64))
        np.maximum.at(self.last_invalid, agents, stamps)

    def _note_late(self, agents: IntArray, stamps: IntArray) -> None:
        """Count truth that would have served a step already skipped without it."""
        late = (self.last_skipped[agents] >= 0) & (stamps >= self.last_skipped[agents])
        if late.any():
            # a step skipped while the agent's truth was invalid: not the clock's lead
            invalid = late & (self.last_invalid[agents] >= self.last_skipped[agents])
            self.stats.late_truth += int(np.unique(agents[late & ~invalid]).size)
            self.stats.invalid_gaps += int(np.unique(agents[invalid]).size)
            self.last_skipped[agents[late]] = -1

    def add_truth_batch(self, agents: Numbers, stamps: Numbers, coords: Numbers) -> BoolArray:
        """
        Store many truth samples at once, in arrival order per agent.

        ``agents`` (m,) local agent indices, ``stamps`` (m,) ns, ``coords``
        (m, 3) lat, lon, alt. Returns a boolean mask of the samples kept (the
        others were at or before their agent's newest stamp).
        """
        agents, stamps = np.asarray(agents, dtype=np.int64), np.asarray(stamps, dtype=np.int64)
        kept = np.zeros(agents.size, dtype=bool)
        if agents.size == 0:
            return kept
        if self.last_now is not None:
            future = stamps > self.last_now + self.future_tolerance_ns
            if future.any():
                self.stats.dropped_future += int(future.sum())
                rest = np.flatnonzero(~future)
                if rest.size:
                    kept[rest] = self._add_batch(agents[rest], stamps[rest],
                                                 np.asarray(coords)[rest],
                                                 np.zeros(rest.size, dtype=bool))
                return kept
        return self._add_batch(agents, stamps, coords, kept)

    def _add_batch(self, agents: IntArray, stamps: IntArray, coords: Numbers,
                   kept: BoolArray) -> BoolArray:
        order = np.argsort(agents, kind='stable')
        sorted_agents = agents[order]
        first = np.r_[0, np.flatnonzero(np.diff(sorted_agents)) + 1]
        rank = np.empty(agents.size, dtype=np.int64)
        rank[order] = np.arange(agents.size) - np.repeat(first, np.diff(np.r_[first, agents.size]))
        for r in range(int(rank.max()) + 1):
            sel = np.flatnonzero(rank == r)
            ok = stamps[sel] > self.truth.newest[agents[sel]]
            sel = sel[ok]
            self.truth.push(agents[sel], stamps[sel], np.asarray(coords)[sel])
            self._note_late(agents[sel], stamps[sel])
            kept[sel] = True
        self.stats.dropped_out_of_order += int((~kept).sum())
        return kept

    # --- agents that come and go ---------------------------------------

    def grow(self, n: int) -> None:
        """Add ``n`` free slots (inactive until attached)."""
        self.keys = np.concatenate([self.keys, np.zeros(n, dtype=np.uint64)])
        self.active = np.concatenate([self.active, np.zeros(n, dtype=bool)])
        self.last_skipped = np.concatenate([self.last_skipped, np.full(n, -1, np.int64)])
        self.last_invalid = np.concatenate([self.last_invalid, np.full(n, -1, np.int64)])
        self.truth.grow(n)
        if self.state is not None:
            self.state = self.state.joined(self.model.empty_state(n))
        for side in self.side.values():
            side.grow(n)
        for step in self.pending:
            step.err = np.concatenate([step.err, np.zeros((n, 2))])
            step.done = np.concatenate([step.done, np.ones(n, dtype=bool)])
            step.fix = np.concatenate([step.fix, np.ones(n, dtype=bool)])
            step.side = {k: np.concatenate([v, np.zeros((n, v.shape[1]))])
                         for k, v in step.side.items()}
            if step.cov is not None:
                step.cov = np.concatenate([step.cov, np.zeros((n, 2, 2))])
        if self.cov_now is not None:
            self.cov_now = np.concatenate([self.cov_now, np.zeros((n, 2, 2))])
        if self.zoned is not None:
            self.zoned.grow(n)
        self.n += n

    def attach(self, slots: Numbers, keys: Keys) -> None:
        """
        Give free ``slots`` to agents with stream ``keys``.

        Each agent's model state is caught up from the start on its own
        stream, and the steps now waiting for truth get its errors, so that
        what it is served does not depend on when it was attached.
        """
        slots = np.asarray(slots, dtype=np.int64)
        keys = np.asarray(keys, dtype=np.uint64)
        if self.active[slots].any():
            raise ValueError(f'slots {slots[self.active[slots]].tolist()} are taken')
        self.keys[slots] = keys
        self.active[slots] = True
        self.truth.clear(slots)
        self.last_skipped[slots] = -1
        self.last_invalid[slots] = -1
        if self.zoned is not None:
            self.zoned.forget(slots)
        if self.faults is not None:
            self.faults.forget(slots.tolist())
        if self.state is None or not slots.size:
            return
        m = self.pending[0].model_step if self.pending else self.model_index
        state, cov = self._caught_up(keys, m)
        for step in self.pending:
            while m < step.model_step:
                m += 1
                cov = model_step(self.model, state, keys, m, cov=cov is not None)
            step.err[slots] = self.model.errors(state)
            step.fix[slots] = self.model.fix_mask(state)
            step.done[slots] = False
            if cov is not None and step.cov is not None:     # both: conditional_cov
                step.cov[slots] = cov
        while m < self.model_index:
            m += 1
            cov = model_step(self.model, state, keys, m, cov=cov is not None)
        self.state.put(slots, state)
        if cov is not None and self.cov_now is not None:   # both: conditional_cov
            self.cov_now[slots] = cov
        for name, side in self.side.items():
            ws = side.history(keys, self.start_index, self.model_index)
            for step in self.pending:
                step.side[name][slots] = ws[step.model_step - self.start_index]
            side.w[slots] = ws[-1]

    def prepare_attach(self) -> None:
        """
        Run :meth:`attach`'s catch-up once on a throwaway agent, to load what it needs.

        The catch-up simulates through ``scipy.signal``, whose import takes
        1-2 s (several on a loaded machine). Paid at the first agent attached
        while a simulator drives the clock, it stopped the node that long:
        the clock ran on past steps whose truth was still queued, and those
        steps got no fix. A node that attaches agents as they come calls
        this before it starts.
        """
        keys, span = np.zeros(1, dtype=np.uint64), 64
        self._caught_up(keys, span, start=0)
        for side in self.side.values():
            side.history(keys, 0, span)

    def _caught_up(self, keys: Keys, m: int,
                   start: int | None = None) -> tuple[S, FloatArray | None]:
        """Return the state at model step ``m`` of agents ``keys``, and its covariance."""
        start = self.start_index if start is None else start
        return state_at(self.model, keys, start, m, cov=self.conditional_cov)

    def detach(self, slots: Numbers) -> None:
        """Free ``slots``: no more fixes for them, their truth forgotten."""
        slots = np.asarray(slots, dtype=np.int64)
        self.active[slots] = False
        self.truth.clear(slots)
        self.last_skipped[slots] = -1
        self.last_invalid[slots] = -1
        if self.zoned is not None:
            self.zoned.forget(slots)
        for step in self.pending:
            step.done[slots] = True

    def on_clock(self, now_ns: int) -> list[FixBatch]:
        """
        Advance to clock time ``now_ns``; return the fixes now ready.

        Returns a list of :class:`FixBatch`, oldest first. A clock reading of 0
        (simulated time not yet received) is ignored. With ``start_ns`` the
        streams begin at its step whenever the first reading comes: readings
        before it are ignored, and the steps from it to the first reading are
        enqueued (served from the truth already received), unless there are
        more than ``max_pending`` of them (counted in ``late_start``; the
        streams then begin at the first reading).
        """
        if now_ns <= 0:
            return []
        if self.last_now is not None and now_ns < self.last_now:
            self.stats.resets += 1
            self.truth.clear()
            self.last_skipped[:] = -1
            self.last_invalid[:] = -1
            self._reset_time()
        self.last_now = now_ns
        due = now_ns // self.period_ns
        first = due if self.last_step is None else self.last_step + 1
        if self.last_step is None and self.start_step is not None:
            if due < self.start_step:
                return []               # the streams have not begun
            if due - self.start_step <= self.max_pending:
                first = self.start_step
            else:
                self.stats.late_start += 1
        for k in range(first, due + 1):
            self._enqueue(k)
        self.last_step = due
        return self.resolve(now_ns)

    # --- internals -------------------------------------------------------

    def _enqueue(self, k: int) -> None:
        t_ns = k * self.period_ns
        m = t_ns // self.model_period_ns
        if self.state is None:
            self.state = self.model.initial_state(self.keys, m)
            self.model_index = self.start_index = m
            self.began_ns = t_ns
            if self.zoned is not None:
                self.zoned.restart(m)
            for side in self.side.values():
                side.start(self.keys, m)
            if self.conditional_cov:
                self.cov_now = self.model.predictive_cov(self.state, first=True)
        while self.model_index < m:
            self.model_index += 1
            cov = model_step(self.model, self.state, self.keys, self.model_index,
                             cov=self.conditional_cov)
            if cov is not None:
                self.cov_now = cov
            for side in self.side.values():
                side.advance(self.keys, self.model_index)
        self.stats.steps += 1
        # free slots are done already
        self.pending.append(PendingStep(
            t_ns, m, self.model.errors(self.state), ~self.active,
            self.model.fix_mask(self.state), {k: v.w.copy() for k, v in self.side.items()},
            None if self.cov_now is None else self.cov_now.copy()))

    def resolve(self, now_ns: int) -> list[FixBatch]:
        """Return fixes for pending steps whose truth is now known."""
        out: list[FixBatch] = []
        while len(self.pending) > self.max_pending:
            out.extend(self._resolve_step(self.pending[0], force=True))
            self.pending.popleft()
            self.stats.pending_overflow += 1
        # Every waiting step is looked at, oldest first, not only up to the
        # first one still waiting for some agent: one agent whose truth is
        # late must not hold back the others' fixes (it did, by max_pose_age,
        # until the agents that come and go showed it). An agent's fixes
        # still come in step order: truth that makes a later step ready for
        # it makes every earlier step of it ready too, and those come first.
        for step in self.pending:
            expired = now_ns >= step.t_ns + self.max_pose_age_ns
            out.extend(self._resolve_step(step, force=expired))
        while self.pending and self.pending[0].done.all():
            self.pending.popleft()
        return out

    def _resolve_step(self, step: PendingStep, force: bool) -> list[FixBatch]:
        t_ns, done = step.t_ns, step.done
        newest = self.truth.newest
        ready = ~done & (newest >= t_ns)
        fixes = []
        if ready.any():
            rows = np.flatnonzero(ready)
            coords, ok = self.truth.interpolate(rows, t_ns - self.lag_ns,
                                                self.max_gap_ns)
            done[rows] = True
            self.stats.skipped_no_truth += int((~ok).sum())
            fixes.append(self._make_fix(step, rows[ok], coords[ok]))
        if force:
            rest = np.flatnonzero(~done)
            if rest.size:
                fresh = (newest[rest] >= 0) & \
                    (t_ns - newest[rest] <= self.max_pose_age_ns)
                held = rest[fresh]
                done[rest] = True
                self.stats.skipped_no_truth += int((~fresh).sum())
                gone = rest[~fresh]
                # an agent that never had truth has not begun: not late
                first = gone[(self.last_skipped[gone] < 0) & (newest[gone] >= 0)]
                self.last_skipped[first] = t_ns
                if held.size:
                    fixes.append(self._make_fix(step, held, self.truth.newest_coord(held)))
        return [f for f in fixes if f.agents.size]

    def _headings(self, agents: IntArray, t_ns: int) -> FloatArray:
        """Return the direction of travel at ``t_ns`` (rad; NaN: standing; see zoned)."""
        now, ok_now = self.truth.interpolate(agents, t_ns - self.lag_ns, self.max_gap_ns)
        back, ok_back = self.truth.interpolate(agents, t_ns - self.lag_ns - NS,
                                               self.max_gap_ns)
        return travel_direction(back[:, 0], back[:, 1], now[:, 0], now[:, 1],
                                ok_now & ok_back)

    def _make_fix(self, step: PendingStep, agents: IntArray, coords: FloatArray) -> FixBatch:
        err, fix = step.err[agents], step.fix[agents]
        cov = None if step.cov is None else step.cov[agents]
        if self.zoned is not None:
            zones = None if self.zone_map is None else \
                self.zone_map.lookup(coords[:, 0], coords[:, 1])
            heading = self._headings(agents, step.t_ns) if self.zoned.needs_heading else None
            err, cov = self.zoned.errors(agents, self.keys[agents], step.model_step, zones,
                                         heading)
        lat, lon = offset(coords[:, 0], coords[:, 1], err[:, 0], err[:, 1])
        lat, lon = np.asarray(lat), np.asarray(lon)
        lat[~fix] = lon[~fix] = np.nan          # no fix: no position
        velocity = velocity_sd = velocity_mean = accuracy = None
        if self.vel is not None:
            velocity, velocity_sd, velocity_mean = self.vel.reported(
                self.truth, agents, step.t_ns, step.side['vel'][agents], self.max_gap_ns)
        if self.reported is not None:       # the phone's stated radius, and its covariance
            accuracy = self.reported.radius(step.side['rep'][agents], cov, self.ref_cov)
            cov = self.reported.covariance(accuracy, self.reported_bias)
        batch = FixBatch(stamp_ns=step.t_ns, agents=agents, lat=lat, lon=lon,
                         alt=coords[:, 2].copy(), error=err, fix=fix, velocity=velocity,
                         velocity_sd=velocity_sd, velocity_mean=velocity_mean, cov=cov,
                         accuracy=accuracy)
        if self.faults is not None and self.faults.faults:
            batch = self._with_faults(batch, coords)
        shown = fix if batch.fix is None else batch.fix
        self.stats.fixes += int(shown.sum())
        self.stats.no_fix += int((~shown).sum())
        return batch

    def _with_faults(self, batch: FixBatch, coords: FloatArray) -> FixBatch:
        """
        Return ``batch`` with the faults on demand that cover it (see :mod:`.faults`).

        A batch a fault touched carries a covariance per fix (``cov_per_fix``).
        """
        if self.faults is None or not self.faults.active_at(batch.stamp_ns):
            return batch
        extra = {k: np.array(v, copy=True) for k, v in (
            ('velocity', batch.velocity), ('velocity_sd', batch.velocity_sd),
            ('velocity_mean', batch.velocity_mean)) if v is not None}
        cov = np.repeat(np.asarray(self.model.stationary_cov)[None], batch.agents.size,
                        axis=0) if batch.cov is None else batch.cov.copy()
        rows = FixRows(batch.stamp_ns, batch.agents, self.keys[batch.agents], coords[:, 0],
                       coords[:, 1], batch.lat.copy(), batch.lon.copy(), batch.alt.copy(),
                       batch.error.copy(),
                       np.ones(batch.agents.size, dtype=bool) if batch.fix is None
                       else batch.fix.copy(), cov, extra)
        if not self.faults.apply(rows).any():
            return batch
        return FixBatch(stamp_ns=batch.stamp_ns, agents=batch.agents, lat=rows.lat,
                        lon=rows.lon, alt=rows.alt, error=rows.error, fix=rows.fix,
                        velocity=rows.extra.get('velocity'),
                        velocity_sd=rows.extra.get('velocity_sd'),
                        velocity_mean=rows.extra.get('velocity_mean'), cov=rows.cov,
                        accuracy=batch.accuracy, cov_per_fix=True)

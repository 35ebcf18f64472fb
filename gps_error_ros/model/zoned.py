"""
Errors whose parameters follow the zone each agent is in.

With a zone map (:mod:`zones`) an agent's error process takes, at every
model step, the parameters of the zone its truth is in.
:class:`WithZones` is that process: an :class:`~.protocol.ErrorModel`
that holds one state per zone process and steps each agent with its
zone's own step (the step's ``inputs.zone``). What the receiver does
beyond the error process (its population draw, gross failures,
availability, covariances about the truth) wraps it, from the default
profile, as without a map (:meth:`~.profiles.Profile.model`). The
transition:

* The AR errors carry over and only the parameters change. The zone wrapper
  keeps each agent's last ``P`` errors of the AR part (mean included, no
  jump; ``P`` the largest order of any zone), and an agent entering zone
  ``z`` continues that zone's recursion from them::

      e(k) = mu_z + sum_i phi_z,i (e(k - i) - mu_z) + s w(k)

  with ``w(k)`` from the agent's stream at step ``k`` (the same draw in
  every zone) and ``s`` the zone's effects. So the error is continuous
  across a boundary: it moves to the new zone's mean and spread at the new
  zone's own pace, and after a few of its correlation times it is a draw
  from the new zone's stationary law.
* What the errors do not carry is the entered zone's own, drawn as a new
  run's is at that step: the variance regime and a jump under way
  (outliers) from their stationary laws, the cycle's phase (periodic) from
  the agent's offset; the direction of travel is the agent's last. While
  the agent stays, they follow the zone's own process.
* An agent's bias and scale (the default profile's ``population``):
  what it reports is ``m_z + f (e - m_z) + b(k)``, ``m_z`` the mean of the
  zone it is in, with the same bias and scale in every zone.
* Which zone a model step belongs to: the zone of the truth that serves
  the agent's fix at that step. Steps an agent gets no fix for are
  advanced with the zone of the next fix's truth; an agent's first steps
  are drawn from the stationary law of the zone of its first fix
  (:class:`~.stepping.StepsPerFix`).
"""

import dataclasses
import math
from typing import Callable, Iterator, Optional, Sequence

import numpy as np

from gps_error_ros.model.effects import MOVING_M
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.motion_lag import between, NS, stamp_ns
from gps_error_ros.model.profiles import Profile
from gps_error_ros.model.protocol import (Inputs, opaque, OpaqueModel, OpaqueProcess, Process,
                                          StepInputs)
from gps_error_ros.model.reported import needs_predictive
from gps_error_ros.model.state import AgentState, BoolArray, FloatArray, IntArray, Keys, Numbers
from gps_error_ros.model.stepping import StepsPerFix
from gps_error_ros.model.zones import OUTSIDE, zone_models, ZoneMap


def travel_direction(lat0: Numbers, lon0: Numbers, lat1: Numbers, lon1: Numbers,
                     ok: Optional[BoolArray] = None) -> FloatArray:
    """
    Return the direction (radians from north, clockwise) from point 0 to point 1.

    NaN where ``ok`` is False or the points are less than ``MOVING_M`` apart
    (standing: the last direction holds).
    """
    north, east = difference(np.asarray(lat1, dtype=float), np.asarray(lon1, dtype=float),
                             np.asarray(lat0, dtype=float), np.asarray(lon0, dtype=float))
    north, east = np.atleast_1d(north), np.atleast_1d(east)
    moving = np.hypot(north, east) >= MOVING_M
    if ok is not None:
        moving &= ok
    return np.where(moving, np.arctan2(east, north), np.nan)


@dataclasses.dataclass(eq=False)
class ZonedState(AgentState):
    """
    The state of :class:`WithZones`.

    Attributes
    ----------
    parts : tuple of states
        One state of every agent per zone process (the one an agent is
        under is current; the others wait for it to enter).
    zone : (n,) int
        The process each agent is under.
    carried : (n, 2, P) float
        The last ``P`` errors of the AR part, mean included, newest first.
    heading : (n,) float
        The last direction of travel known, radians (0 until one is).

    """

    parts: tuple[AgentState, ...]
    zone: IntArray
    carried: FloatArray
    heading: FloatArray


class WithZones(Process[ZonedState]):
    """
    The error process of the zone each agent is in (see the module docstring).

    Parameters
    ----------
    processes
        The zones' error processes, in the zone map's order, then the
        default's last (zone index ``OUTSIDE`` = -1 picks it). Zones with
        the same process object share it: moving between them is not
        entering a new zone.

    """

    def __init__(self, processes: Sequence[OpaqueProcess]) -> None:
        assert OUTSIDE == -1
        self.processes: list[OpaqueProcess] = []
        index: dict[int, int] = {}
        for m in processes:
            if id(m) not in index:
                index[id(m)] = len(self.processes)
                self.processes.append(m)
        #: zone index (OUTSIDE = -1 is the last entry) -> distinct process
        self.process_of_zone = np.array([index[id(m)] for m in processes], dtype=np.int64)
        self.default = self.processes[int(self.process_of_zone[-1])]
        self.order = max(m.order for m in self.processes)
        self.lag_s = self.default.lag_s
        self.needs_heading = any(m.needs_heading for m in self.processes)
        self._means = np.array([m.mean for m in self.processes], dtype=float)
        #: the default process's stationary mean (outside every zone), north and east
        self.mean = self.default.mean

    # --- the default's moments (outside every zone) ------------------------

    @property
    def stationary_cov(self) -> FloatArray:
        """Return the default process's stationary covariance (2, 2)."""
        return self.default.stationary_cov

    @property
    def stationary_sd(self) -> FloatArray:
        """Return the default process's stationary standard deviation per axis."""
        return self.default.stationary_sd

    def autocovariance(self, max_lag: int) -> FloatArray:
        """Return the default process's autocovariance, (max_lag + 1, 2, 2)."""
        return self.default.autocovariance(max_lag)

    def autocorrelation(self, max_lag: int) -> FloatArray:
        """Return the default process's autocorrelation per axis, (max_lag + 1, 2)."""
        return self.default.autocorrelation(max_lag)

    def mean_step_cov(self) -> FloatArray:
        """Return the default process's mean one-step covariance (2, 2)."""
        return self.default.mean_step_cov()

    # --- state and the step ------------------------------------------------

    def _zones(self, inputs: Inputs, n: int) -> IntArray:
        """Return each agent's process index from the inputs' zones (none: the default)."""
        if inputs is None or inputs.zone is None:
            return np.full(n, self.process_of_zone[-1], dtype=np.int64)
        return self.process_of_zone[np.asarray(inputs.zone, dtype=np.int64)]

    def _groups(self, zones: IntArray) -> Iterator[tuple[int, IntArray]]:
        for z in np.unique(zones):
            yield int(z), np.flatnonzero(zones == z)

    def empty_state(self, n: int) -> ZonedState:
        """Return the state of ``n`` agents, all zeros, in the default process."""
        return ZonedState(tuple(m.empty_state(n) for m in self.processes),
                          np.full(n, self.process_of_zone[-1], dtype=np.int64),
                          np.zeros((n, 2, self.order)), np.zeros(n))

    def _set(self, state: ZonedState, z: int, rows: IntArray, part: AgentState) -> None:
        """Write ``part`` as ``rows``' state under process ``z``; carry its errors."""
        m = self.processes[z]
        state.parts[z].put(rows, part)
        state.zone[rows] = z
        own = m.carried(part)
        state.carried[rows] = m.mean[None, :, None]     # lags beyond the process's p: its mean
        state.carried[rows, :, :own.shape[2]] = own

    def _headed(self, state: ZonedState, inputs: Inputs) -> None:
        """Keep the last finite direction of travel of every agent."""
        if inputs is not None and inputs.heading is not None:
            heading = np.asarray(inputs.heading, dtype=float)
            moving = np.isfinite(heading)
            state.heading[moving] = heading[moving]

    def initial_state(self, keys: Keys, index: int, inputs: Inputs = None) -> ZonedState:
        """Draw the state at ``index``: each agent from its zone process's stationary law."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        state = self.empty_state(keys.size)
        self._headed(state, inputs)
        for z, r in self._groups(self._zones(inputs, keys.size)):
            sub = None if inputs is None else inputs.take(r)
            self._set(state, z, r, self.processes[z].initial_state(keys[r], index, sub))
        return state

    def state_after(self, keys: Keys, start: int, step: int, inputs: Inputs = None) -> ZonedState:
        """Return the state at ``step`` of a run from ``start`` in the zones of ``inputs``."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        state = self.empty_state(keys.size)
        self._headed(state, inputs)
        for z, r in self._groups(self._zones(inputs, keys.size)):
            sub = None if inputs is None else inputs.take(r)
            self._set(state, z, r, self.processes[z].state_after(keys[r], start, step, sub))
        return state

    def prepare(self, state: ZonedState, keys: Keys, index: int, inputs: Inputs = None) -> None:
        """Move the agents entering a zone at step ``index`` to its process (module doc)."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        self._headed(state, inputs)
        for z, r in self._groups(self._zones(inputs, keys.size)):
            m, sub = self.processes[z], None if inputs is None else inputs.take(r)
            entering = r[state.zone[r] != z]
            if entering.size:
                state.parts[z].put(entering, m.resumed(
                    state.carried[entering], keys[entering], index,
                    StepInputs(heading=state.heading[entering])))
                state.zone[entering] = z
            if sub is not None and sub.heading is not None:
                part = self._part(state, z, r)
                m.prepare(part, keys[r], index, sub)
                if part is not state.parts[z]:
                    state.parts[z].put(r, part)

    def advance(self, state: ZonedState, keys: Keys, index: int,
                inputs: Inputs = None) -> FloatArray:
        """Advance each agent with its zone's process to step ``index``; return the errors."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        self.prepare(state, keys, index, inputs)
        out = np.empty((keys.size, 2))
        for z, r in self._groups(state.zone):
            m, sub = self.processes[z], None if inputs is None else inputs.take(r)
            part = self._part(state, z, r)
            out[r] = m.advance(part, keys[r], index, sub)
            if part is not state.parts[z]:
                state.parts[z].put(r, part)
            state.carried[r, :, 1:] = state.carried[r, :, :-1]
            state.carried[r, :, 0] = m.carried(part)[:, :, 0]
        return out

    def _part(self, state: ZonedState, z: int, rows: IntArray) -> AgentState:
        """Return process ``z``'s state of ``rows`` (the part itself when they are everyone)."""
        if rows.size == len(state):       # every agent in one zone: rows are 0..n-1
            return state.parts[z]
        return state.parts[z].take(rows)

    def _per_process(self, state: ZonedState, shape: tuple[int, ...],
                     member: Callable[[OpaqueProcess, AgentState], FloatArray]) -> FloatArray:
        """Return ``member(process, its agents' state)`` of each agent's process, (n, *shape)."""
        out = np.empty((len(state),) + shape)
        for z, r in self._groups(state.zone):
            out[r] = member(self.processes[z], self._part(state, z, r))
        return out

    def errors(self, state: ZonedState) -> FloatArray:
        """Return the current north/east errors of every agent, (n, 2)."""
        return self._per_process(state, (2,), lambda m, part: m.errors(part))

    def means(self, state: ZonedState) -> FloatArray:
        """Return the stationary mean (n, 2) of each agent's zone process."""
        return self._means[state.zone]

    def predictive_cov(self, state: ZonedState, first: bool = False) -> FloatArray:
        """Return each agent's covariance (n, 2, 2) of the next error under its process."""
        return self._per_process(state, (2, 2), lambda m, part: m.predictive_cov(part, first))

    def predictive_mean(self, state: ZonedState, first: bool = False) -> FloatArray:
        """Return each agent's expected next error (n, 2) under its process."""
        return self._per_process(state, (2,), lambda m, part: m.predictive_mean(part, first))

    def simulate(self, keys: Keys, n_steps: int, start: int = 0,
                 out: Optional[FloatArray] = None) -> FloatArray:
        """Return errors at steps ``start ..`` with every agent outside every zone."""
        return self.default.simulate(keys, n_steps, start=start, out=out)


#: What the engine, the crowd and ``simulate`` take as ``zones``: a zone map and the
#: agents stepped per fix (the map None: a street frame, no map).
ZoneSetup = tuple[Optional[ZoneMap], StepsPerFix[AgentState]]


def zoned_errors(zone_map: ZoneMap, profile: Profile, covariance_mode: str = 'stationary',
                 about_truth: bool = False
                 ) -> tuple[Profile, OpaqueModel, tuple[ZoneMap, StepsPerFix[AgentState]]]:
    """
    Return (default profile, its model, ``(zone_map, StepsPerFix)``) for a run.

    The default profile is the map's ``default_profile``, else ``profile``;
    its model gives what is not the error process (availability, the
    population, gross failures) and the error outside every zone; the
    zones' processes are wrapped the same way. ``about_truth``: the stated
    covariances are the error's mean square about the truth
    (:mod:`about_truth`).
    """
    default, processes = zone_models(zone_map, profile)
    zoned = default.model(about_truth=about_truth, process=opaque(WithZones(processes)))
    return default, default.model(about_truth=about_truth), (zone_map, StepsPerFix(
        zoned, conditional_cov=needs_predictive(covariance_mode, default.reported_accuracy)))


def simulate_along(zoned: StepsPerFix[AgentState], keys: Keys, steps: Numbers,
                   zones: Numbers) -> FloatArray:
    """
    Return errors (n samples, agents, 2) simulated along sampled steps in zones.

    ``steps`` (n,) increasing model steps from 0 where a trace has samples,
    ``zones`` (n,) the zone of each sample. Every agent runs continuously
    from step 0; a step without a sample takes the zone of the next sample
    (the rule of the module doc). ``zoned`` is a fresh :class:`StepsPerFix`.
    """
    steps = np.asarray(steps, dtype=np.int64)
    span = int(steps[-1]) + 1
    nxt = np.minimum(np.searchsorted(steps, np.arange(span)), steps.size - 1)
    zone_at = np.asarray(zones, dtype=np.int64)[nxt]
    keys = np.asarray(keys, dtype=np.uint64)
    zoned.grow(keys.size - zoned.n)
    zoned.restart(0)
    rows = np.arange(keys.size)
    out = np.empty((steps.size, keys.size, 2))
    j = 0
    for k in range(span):
        e = zoned.errors(rows, keys, k, np.full(keys.size, zone_at[k]))[0]
        while j < steps.size and steps[j] == k:
            out[j] = e
            j += 1
    return out


class TravelDirections:
    """
    Each named agent's direction of travel, from truth streamed step by step.

    What the engine computes for the node, for ``simulate``: the direction
    from the truth ``lag_s`` + 1 s before a step to the truth ``lag_s``
    before it, each interpolated linearly in latitude and longitude between
    the samples around it; NaN (the last direction holds) before the truth
    reaches back that far or when it moved less than ``MOVING_M``.
    """

    def __init__(self, lag_s: float = 0.0) -> None:
        self.lag_s = float(lag_s)
        self.lag_ns = int(round(self.lag_s * NS))
        self.hist: dict[str, list[tuple[float, float, float]]] = {}

    def _at(self, h: list[tuple[float, float, float]], when: int) -> tuple[float, float]:
        for a, b in zip(h[:-1], h[1:]):
            if a[0] <= when <= b[0]:
                return between(a, b, when)
        if h and h[-1][0] == when:
            return h[-1][1], h[-1][2]
        return math.nan, math.nan

    def directions(self, names: Sequence[str], t: float, lat: Numbers,
                   lon: Numbers) -> FloatArray:
        """Store (t, lat, lon) per agent; return each one's direction now (rad or NaN)."""
        out = np.full(len(names), np.nan)
        t_ns = stamp_ns(t)
        back = t_ns - self.lag_ns - NS
        pts = np.full((len(names), 4), np.nan)
        for i, n in enumerate(names):
            h = self.hist.setdefault(n, [])
            h.append((float(t_ns), float(lat[i]), float(lon[i])))
            while len(h) > 2 and h[1][0] <= back:
                h.pop(0)
            pts[i, :2] = self._at(h, back)
            pts[i, 2:] = self._at(h, t_ns - self.lag_ns)
        ok = np.isfinite(pts).all(axis=1)
        if ok.any():
            out[ok] = travel_direction(pts[ok, 0], pts[ok, 1], pts[ok, 2], pts[ok, 3])
        return out

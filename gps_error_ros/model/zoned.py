"""
Errors whose parameters follow the zone each agent is in.

With a zone map (:mod:`zones`) an agent's error process takes, at every
model step, the parameters of the zone its truth is in. The transition:

* The state carries over and only the parameters change. The state holds
  the last ``P`` errors themselves (mean included, ``P`` the largest order of
  any zone), and a step in zone ``z`` is that zone's recursion on them::

      e(k) = mu_z + sum_i phi_z,i (e(k - i) - mu_z) + s w(k)

  with ``w(k)`` from the agent's stream at step ``k`` (the same draw in
  every zone) and ``s`` the zone's effects (coupling, heavy tails,
  regimes). So the error is continuous across a boundary: it moves to the
  new zone's mean and spread at the new zone's own pace, and after a few of
  its correlation times it is a draw from the new zone's stationary law.
* Variance regimes: an agent entering a zone with regimes draws its regime
  from that zone's stationary regime law (the stream's initial-regime draw at
  that step); while it stays, the regime follows the zone's chain.
* Gross failures (the default profile's ``gross_failures`` section, as
  availability comes from it): at a step where the fix failed, the failure
  replaces the zone's error, and the zone's process runs on beneath it, as
  :class:`~.failures.WithFailures` does without zones; the same draws, so a
  failure falls at the same step and place in every zone.
* An agent's bias and scale (the default profile's ``population`` section,
  as availability comes from it): the zone's process runs as above, and
  what the agent reports is ``m_z + f (e - m_z) + b(k)``, ``m_z`` the mean
  of the zone it is in, ``f`` the agent's scale and ``b`` its run's bias
  and wander, drawn as without zones (:class:`~.population.AgentDraws`):
  the same bias and scale in every zone, and outside every zone the same
  errors as the default profile's model without a map. The stated
  covariances cover the population as :class:`~.population.WithPopulation`
  does (the bias spread in the stationary one; given the state, the
  agent's scale and bias known).
* Which zone a model step belongs to: the zone of the truth that serves
  the agent's fix at that step. Steps an agent gets no fix for (no truth, a
  later attach) are advanced with the zone of the next fix's truth; an
  agent's first steps are drawn from the stationary law of the zone of its
  first fix. Given the truth, everything is a pure function of (seed, agent
  name, step): the node, ``simulate`` and every shard agree.

Errors are computed when an agent's fix is made, not when the step comes
due, because the zone is known only once the truth for the step is.
"""

import math
from typing import Any, Iterator, Optional, Sequence

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.about_truth import AboutTruth, mean_square
from gps_error_ros.model.availability import WithAvailability
from gps_error_ros.model.effects import ExtendedModel, MOVING_M
from gps_error_ros.model.failures import GrossFailureProcess, WithFailures
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.population import AgentDraws, WithPopulation
from gps_error_ros.model.profiles import Profile
from gps_error_ros.model.protocol import ErrorModel
from gps_error_ros.model.reported import needs_predictive
from gps_error_ros.model.state import BoolArray, FloatArray, IntArray, Keys, Numbers
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


def _core(model: ErrorModel[Any]) -> tuple[ErrorModel[Any], bool]:
    """Return (the model beneath an :class:`AboutTruth`, whether it was wrapped)."""
    return (model.core, True) if isinstance(model, AboutTruth) else (model, False)


def _process(model: ErrorModel[Any]) -> ExtendedModel:
    """Return the process with effects beneath any :class:`AboutTruth`."""
    core = _core(model)[0]
    if not isinstance(core, ExtendedModel):
        raise TypeError(f'expected a model with effects, got {type(core).__name__}')
    return core


def _has_regimes(model: ErrorModel[Any]) -> bool:
    """Return True when the process (beneath any :class:`AboutTruth`) has variance regimes."""
    core = _core(model)[0]
    return isinstance(core, ExtendedModel) and core.scales.size > 1


#: Per-slot arrays of :class:`ZonedErrors` (grown, kept and forgotten together).
_SLOT_ARRAYS = ('err', 'regime', 'zone', 'step', 'started', 'cov', 'heading',
                'bias', 'scale', 'bias_factor', 'held')


class ZonedErrors:
    """
    Per-slot error state over zone models, advanced lazily per agent.

    Parameters
    ----------
    models
        The error models of the zones, in the zone map's order, then the
        default model last (zone index ``OUTSIDE`` = -1 picks it). Zones
        with the same model object are stepped together, and moving between
        them is not entering a new zone (the regime carries on).
    n
        Slots to start with (more with :meth:`grow`).
    conditional_cov
        Covariance of each error given the state a step before (the node's
        ``covariance_mode`` conditional); else the zone's stationary one.
    failures
        The gross failures of every zone (the default profile's section).
    population
        Each agent's bias and scale in every zone (the default profile's
        ``population`` section).

    """

    def __init__(self, models: Sequence[ErrorModel[Any]], n: int = 0,
                 conditional_cov: bool = False,
                 failures: Optional[GrossFailureProcess] = None,
                 population: Optional[AgentDraws] = None) -> None:
        assert OUTSIDE == -1
        self.models: list[ErrorModel[Any]] = []      # distinct models
        index: dict[int, int] = {}
        for m in models:
            if id(m) not in index:
                index[id(m)] = len(self.models)
                self.models.append(m)
        # zone index (OUTSIDE = -1 is the last entry) -> distinct model
        self.model_of_zone = np.array([index[id(m)] for m in models], dtype=np.int64)
        self.order = max(m.order for m in self.models)
        self.conditional_cov = conditional_cov
        self.failures = failures
        self.population = population
        self.means = np.array([m.mean for m in self.models], dtype=float)
        self.stationary = np.array([m.stationary_cov for m in self.models])
        if population is not None:
            self.stationary = self.stationary + population.spread
        #: whether any zone's innovations turn with the direction of travel
        self.needs_heading = any(m.needs_heading for m in self.models)
        self.start: Optional[int] = None
        self._alloc(n)

    def _alloc(self, n: int) -> None:
        self.err = np.zeros((n, 2, self.order))    # last P errors, newest first
        self.regime = np.zeros(n, dtype=np.int64)
        self.zone = np.zeros(n, dtype=np.int64)    # the distinct model in use
        self.step = np.zeros(n, dtype=np.int64)    # last model step advanced
        self.started = np.zeros(n, dtype=bool)
        self.cov = np.zeros((n, 2, 2))             # of the current error
        self.heading = np.zeros(n)                 # last direction of travel, rad
        self.bias = np.zeros((n, 2))               # the run's bias (population)
        self.scale = np.ones(n)                    # the agent's scale f
        self.bias_factor = np.ones(n)              # the run's Student-t factor g
        self.held = np.zeros((n, 2))               # the part of the bias held for the run

    @property
    def n(self) -> int:
        """Return the number of slots."""
        return self.started.size

    def grow(self, n: int) -> None:
        """Add ``n`` slots (not started)."""
        old = [getattr(self, k) for k in _SLOT_ARRAYS]
        self._alloc(n)
        for k, a in zip(_SLOT_ARRAYS, old):
            setattr(self, k, np.concatenate([a, getattr(self, k)]))

    def keep(self, mask: BoolArray) -> None:
        """Keep only the slots where ``mask`` is True (in order)."""
        for name in _SLOT_ARRAYS:
            setattr(self, name, getattr(self, name)[mask])

    def restart(self, start: int, rows: Any = slice(None)) -> None:
        """Forget ``rows`` (all by default); runs count from model step ``start``."""
        self.start = int(start)
        self.started[rows] = False

    def forget(self, rows: Any) -> None:
        """Forget ``rows``: their next fix starts them again from the run's start."""
        self.started[rows] = False
        self.heading[rows] = 0.0

    def errors(self, rows: IntArray, keys: Keys, step: int, zones: IntArray,
               heading: Optional[FloatArray] = None) -> tuple[FloatArray, FloatArray]:
        """
        Return the error, shape (m, 2), and covariance (m, 2, 2) of ``rows`` at a step.

        ``keys`` are the rows' stream keys and ``zones`` the zone index of
        each row's truth now (``OUTSIDE`` for the default); ``heading`` the
        direction of travel now (radians; NaN standing: the last one holds),
        for street_frame. Rows behind are advanced to model step ``step``
        first, in the zone and direction of now (see the module doc).
        """
        rows = np.asarray(rows, dtype=np.int64)
        keys = np.asarray(keys, dtype=np.uint64)
        zones = self.model_of_zone[np.asarray(zones, dtype=np.int64)]
        if self.start is None:
            raise ValueError('ZonedErrors.restart(start) was not called')
        if heading is not None:
            heading = np.asarray(heading, dtype=float)
            moving = np.isfinite(heading)
            self.heading[rows[moving]] = heading[moving]
        fresh = ~self.started[rows]
        if fresh.any():
            self._begin(rows[fresh], keys[fresh], step, zones[fresh])
        if np.any(self.step[rows] > step):
            raise ValueError(f'model step {step} is before the last step served '
                             f'({int(self.step[rows].max())})')
        behind = np.flatnonzero(self.step[rows] < step)
        if behind.size:
            r, k, z = rows[behind], keys[behind], zones[behind]
            for s in range(int(self.step[r].min()) + 1, step + 1):
                due = self.step[r] < s
                self._advance(r[due], k[due], s, z[due])
        cov = self.cov[rows] if self.conditional_cov else self.stationary[self.zone[rows]]
        err = self.err[rows, :, 0].copy()
        if self.population is not None:             # m + f (e - m) + b
            m = self.means[self.zone[rows]]
            err = m + self.scale[rows, None] * (err - m) + self.bias[rows]
            if self.population.held:
                err += self.held[rows]
        if self.failures is not None:
            off, fails = self.failures.offsets(keys, step)
            err[fails] = off[fails]
        return err, cov

    def _groups(self, zones: IntArray) -> Iterator[tuple[int, IntArray]]:
        for z in np.unique(zones):
            yield int(z), np.flatnonzero(zones == z)

    def _begin(self, rows: IntArray, keys: Keys, step: int, zones: IntArray) -> None:
        """Start ``rows`` at ``step``: the state of a run from the start in one zone."""
        if self.population is not None:            # the bias a step before, the scale
            self._draw(rows, keys, step)
        for z, sel in self._groups(zones):
            model, r, k = self.models[z], rows[sel], keys[sel]
            if model.needs_heading:
                state = self._street_start(model, r, k, step)
            elif self.conditional_cov:
                state = self._conditional_start(model, r, k, step)
            else:
                state = model.state_after(k, self._start(), step)
            p = model.order
            self.err[r] = model.mean[None, :, None]       # lags beyond p: the mean
            self.err[r, :, :p] = state.deviations + model.mean[None, :, None]
            self.regime[r] = state.regime if _has_regimes(model) else 0
            self.zone[r] = z
            self.step[r] = step
            self.started[r] = True
        if self.population is not None and step > self._start():
            self._wander(rows, keys, step)

    def _start(self) -> int:
        """Return the run's first model step (set by :meth:`restart`)."""
        if self.start is None:
            raise ValueError('ZonedErrors.restart(start) was not called')
        return self.start

    def _draws(self) -> AgentDraws:
        """Return the population's draws (only called when there is a population)."""
        if self.population is None:
            raise ValueError('this ZonedErrors has no population')
        return self.population

    def _draw(self, rows: IntArray, keys: Keys, step: int) -> None:
        """Draw the agents' scales and their runs' biases, wandered to ``step - 1``."""
        draws, start = self._draws(), self._start()
        self.bias[rows], self.bias_factor[rows] = draws.bias_at(keys, start, step - 1)
        self.scale[rows] = draws.scales(keys)
        self.held[rows] = draws.held_part(keys, start, self.bias_factor[rows])

    def _wander(self, rows: IntArray, keys: Keys, step: int) -> None:
        """Wander the runs' biases of ``rows`` to model step ``step``."""
        bias = self.bias[rows]
        self._draws().wander(bias, self.bias_factor[rows], keys, step)
        self.bias[rows] = bias

    def _stated(self, model: ErrorModel[Any], rows: IntArray, state: Any,
                first: bool = False) -> FloatArray:
        """Return the covariances (m, 2, 2) of ``rows``' next errors given ``state``."""
        if self.population is None:
            return model.predictive_cov(state, first)
        core, about = _core(model)
        draws, scale = self.population, self.scale[rows]
        cov = draws.agent_cov(core.predictive_cov(state, first), scale,
                              self.bias_factor[rows], first)
        if not about:
            return cov
        return mean_square(cov, draws.agent_mean(core.mean, core.predictive_mean(state, first),
                                                 scale, self.bias[rows], first,
                                                 self.held[rows] if draws.held else None))

    def _conditional_start(self, model: ErrorModel[Any], rows: IntArray, keys: Keys,
                           step: int) -> Any:
        """Return the state at ``step`` of a run from the start; set its covariance."""
        if step == self.start:
            state = model.initial_state(keys, step)
            self.cov[rows] = self._stated(model, rows, state, first=True)
            return state
        state = model.state_after(keys, self._start(), step - 1)
        self.cov[rows] = self._stated(model, rows, state)
        model.advance(state, keys, step)
        return state

    def _street_start(self, model: ErrorModel[Any], rows: IntArray, keys: Keys, step: int) -> Any:
        """Return the state at ``step`` of a street-frame run from the start, heading now."""
        if step == self.start:
            state = model.initial_state(keys, step)
            model.face(state, self.heading[rows])
            if self.conditional_cov:
                self.cov[rows] = self._stated(model, rows, state, first=True)
            return state
        state = model.state_after(keys, self._start(), step - 1, heading=self.heading[rows])
        if self.conditional_cov:
            self.cov[rows] = self._stated(model, rows, state)
        model.advance(state, keys, step)
        return state

    def _advance(self, rows: IntArray, keys: Keys, step: int, zones: IntArray) -> None:
        """Advance ``rows`` (one step behind) to ``step`` with their zones' recursions."""
        for z, sel in self._groups(zones):
            model, r, k = self.models[z], rows[sel], keys[sel]
            p = model.order
            tmp = model.empty_state(r.size)
            tmp.deviations[:] = self.err[r, :, :p] - model.mean[None, :, None]
            if model.needs_heading:
                model.face(tmp, self.heading[r])
            if _has_regimes(model):
                regime = self.regime[r].copy()
                entering = self.zone[r] != z
                if entering.any():
                    u = streams.uniform_pairs(k[entering], streams.DOMAIN_INIT_REGIME,
                                              step)[:, 0]
                    regime[entering] = np.searchsorted(_process(model).cum_pi, u, side='right')
                tmp.regime[:] = regime
            if self.conditional_cov:
                self.cov[r] = self._stated(model, r, tmp)
            e = model.advance(tmp, k, step)
            self.err[r, :, 1:] = self.err[r, :, :-1]
            self.err[r, :, 0] = e
            self.regime[r] = tmp.regime if _has_regimes(model) else 0
            self.zone[r] = z
            self.step[r] = step
        if self.population is not None:
            self._wander(rows, keys, step)


#: What the engine, the crowd and ``simulate`` take as ``zones``: a zone map and the
#: errors per zone (the map None: a street frame, everyone in one zone).
ZoneSetup = tuple[Optional[ZoneMap], ZonedErrors]


def one_zone(model: ErrorModel[Any], conditional_cov: bool = False) -> ZonedErrors:
    """
    Return the :class:`ZonedErrors` of a street-frame model without a zone map.

    A street frame needs each fix's direction of travel, which the
    zone path carries: one zone, the error process beneath the availability
    and failure wrappers, with the failures and the population's draws
    applied as in zones.
    """
    failures = None
    while isinstance(model, (WithAvailability, WithFailures)):
        failures = getattr(model, 'failures', failures)
        model = model.inner
    core, about = _core(model)
    draws = None
    if isinstance(core, WithPopulation):
        draws = core.draws
        model = AboutTruth(core.inner) if about else core.inner
    return ZonedErrors([model], conditional_cov=conditional_cov, failures=failures,
                       population=draws)


def zoned_errors(zone_map: ZoneMap, profile: Profile, covariance_mode: str = 'stationary',
                 about_truth: bool = False
                 ) -> tuple[Profile, ErrorModel[Any], tuple[ZoneMap, ZonedErrors]]:
    """
    Return (default profile, its model, ``(zone_map, ZonedErrors)``) for a run.

    The default profile is the map's ``default_profile``, else ``profile``;
    its model gives what is not the error process (availability) and the
    error outside every zone. ``about_truth``: the stated covariances are
    the error's mean square about the truth (:mod:`about_truth`).
    """
    default, models = zone_models(zone_map, profile, about_truth)
    draws = None if default.population is None else \
        AgentDraws(default.population, default.rate_hz)
    return default, default.model(about_truth=about_truth), (zone_map, ZonedErrors(
        models, conditional_cov=needs_predictive(covariance_mode, default.reported_accuracy),
        failures=default.gross_failures, population=draws))


def simulate_along(zoned: ZonedErrors, keys: Keys, steps: Numbers, zones: Numbers) -> FloatArray:
    """
    Return errors (n samples, agents, 2) simulated along sampled steps in zones.

    ``steps`` (n,) increasing model steps from 0 where a trace has samples,
    ``zones`` (n,) the zone of each sample. Every agent runs continuously
    from step 0; a step without a sample takes the zone of the next sample
    (the rule of the module doc). ``zoned`` is a fresh :class:`ZonedErrors`.
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
        self.hist: dict[str, list[tuple[float, float, float]]] = {}

    def _at(self, h: list[tuple[float, float, float]], when: float) -> tuple[float, float]:
        for (t0, a0, b0), (t1, a1, b1) in zip(h[:-1], h[1:]):
            if t0 <= when <= t1:
                w = (when - t0) / (t1 - t0) if t1 > t0 else 0.0
                return a0 + w * (a1 - a0), b0 + w * (b1 - b0)
        if h and h[-1][0] == when:
            return h[-1][1], h[-1][2]
        return math.nan, math.nan

    def directions(self, names: Sequence[str], t: float, lat: Numbers,
                   lon: Numbers) -> FloatArray:
        """Store (t, lat, lon) per agent; return each one's direction now (rad or NaN)."""
        out = np.full(len(names), np.nan)
        back = t - self.lag_s - 1.0
        pts = np.full((len(names), 4), np.nan)
        for i, n in enumerate(names):
            h = self.hist.setdefault(n, [])
            h.append((t, float(lat[i]), float(lon[i])))
            while len(h) > 2 and h[1][0] <= back:
                h.pop(0)
            pts[i, :2] = self._at(h, back)
            pts[i, 2:] = self._at(h, t - self.lag_s)
        ok = np.isfinite(pts).all(axis=1)
        if ok.any():
            out[ok] = travel_direction(pts[ok, 0], pts[ok, 1], pts[ok, 2], pts[ok, 3])
        return out

"""
A population of phones and runs: each agent's own bias and scale.

A profile fitted on one stretch describes that stretch: its mean error is
the bias of that run, and another day, another walk or another phone of the
same kind has another. The optional ``population`` section makes the
profile describe the receiver across runs (``gps_error calibrate`` fits it
from several recordings, or from the blocks of one long recording: see
:mod:`gps_error_ros.fit.population_fit`). The section::

    population:
      # SD of a run's bias about the profile's mean, north/east
      bias_sd_m: [1.9, 2.4]
      # optional: the bias wanders (first-order Gauss-Markov)
      bias_time_constant_s: 1800
      # SD of the log of an agent's scale of the deviations
      scale_sd_log: 0.25
      # optional: a run's bias is Student-t (heavy-tailed)
      bias_dof: 4
      # optional: SD of a part of the bias held for the whole run
      run_bias_sd_m: [0.5, 3.8]

An agent's error at model step ``k`` is::

    e(k) = m + f * d(k) + b(k)

with ``m`` the profile's mean error and ``d(k)`` the deviation of its error
process (effects and jumps included); ``f = exp(s z - s^2)``, ``z``
standard normal, is the agent's scale (``s`` the ``scale_sd_log``; the mean
of ``f^2`` is 1, so the population's average variance is the process's);
``b(k)`` the run's bias, drawn at the agent's first step from ``N(0,
diag(bias_sd_m^2))``. Without ``bias_time_constant_s`` it holds for the
run; with it, ``b(k) = a b(k-1) + sqrt(1 - a^2) bias_sd_m v(k)``, ``a =
exp(-1 / (time constant x rate))``, stationary at the same SD.

With ``bias_dof`` (an integer in [3, :data:`MAX_BIAS_DOF`]) the bias is
Student-t with that many degrees of freedom and the same SD: ``b`` and its
wander are multiplied by the run's factor ``g = sqrt((dof - 2) / chi2)``,
``chi2`` a chi-square draw with ``dof`` degrees of freedom, fixed for the
run. It is what the bias of a new occasion is, predicted from the few
occasions a fit saw (see :mod:`gps_error_ros.fit.population_fit`).

With ``run_bias_sd_m`` the bias has two parts on two time scales: ``b(k) =
c + w(k)``, ``w`` the wandering part above (``bias_sd_m``, the time
constant) and ``c`` a part held for the whole run, drawn at the start from
``N(0, diag(run_bias_sd_m^2))`` and multiplied by the same ``g``. A
receiver whose bias differs between occasions by more than it wanders
within one (the pedestrian walks) needs both.

Draws: the scale from the stream domain ``population_scale`` at position 0
(an agent's phone keeps its scale whenever it starts); the initial bias
from ``init_bias`` at the start step; the wander from ``bias`` at each
step; a Student-t bias's chi-square from ``bias_mix``, ``ceil(dof / 2)``
normal pairs at the start step's first initial-state positions; the part
held for the run from ``run_bias`` at the start step. One agent
alone, in a crowd or in a shard has the same errors.

Covariances (``stationary_cov`` and ``predictive_cov``): a consumer that
knows nothing of the agent (the stationary covariance, and the first step's
conditional one: a run's first error is drawn from the stationary law) covers
the population's spread, ``C + diag(bias_sd_m^2 + run_bias_sd_m^2)`` with
``C`` the process's stationary covariance;
given the state a step before (the ``conditional`` mode) the agent's scale
and bias are known, so it is ``f^2`` times the process's one-step
covariance plus the bias's own one-step variance ``(1 - a^2) g^2
bias_sd_m^2`` (``g`` 1 for a normal bias).
"""

import dataclasses
from dataclasses import dataclass
import math
from typing import Any, Optional

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.protocol import ErrorModel, Inputs
from gps_error_ros.model.section_spec import Field, SectionSpec
from gps_error_ros.model.state import FloatArray, Inner, Keys, WrappedState
from gps_error_ros.model.wrapped import Wrapper

#: The most degrees of freedom a Student-t bias may have (beyond, it is all but normal).
MAX_BIAS_DOF = 30
#: The largest bias SD a profile may carry, m.
MAX_BIAS_SD_M = 1000.0
#: The largest SD of the log scale (a factor of e^2 between phones at 1 SD).
MAX_SCALE_SD_LOG = 2.0


class PopulationError(ValueError):
    """A ``population`` section that is not valid."""


#: The ``population`` section, field by field.
SECTION = SectionSpec('population', (
    Field('bias_sd_m', 'SD of a run\'s bias about the profile\'s mean (m)', kind='pair',
          lo=0.0, hi=MAX_BIAS_SD_M, digits=4),
    Field('scale_sd_log', 'SD of the log of an agent\'s scale of the deviations', lo=0.0,
          hi=MAX_SCALE_SD_LOG, digits=4),
    Field('bias_time_constant_s', 'the bias wanders, first-order Gauss-Markov with this '
          'time constant (s)', lo=0.0, hi=1e9, lo_open=True,
          absent='a bias constant for the run', digits=1),
    Field('bias_dof', 'a run\'s bias is Student-t with these degrees of freedom',
          kind='integer', lo=3, hi=MAX_BIAS_DOF, absent='a normal bias'),
    Field('run_bias_sd_m', 'SD of a part of the bias held for the whole run (m)',
          kind='pair', lo=0.0, hi=MAX_BIAS_SD_M, absent='no held part', digits=4),
), PopulationError)


@dataclass(frozen=True)
class Population:
    """The parsed section (see the module docstring)."""

    bias_sd_m: tuple[float, ...]
    scale_sd_log: float
    bias_time_constant_s: Optional[float] = None
    bias_dof: Optional[int] = None
    run_bias_sd_m: Optional[tuple[float, ...]] = None

    def to_dict(self) -> dict[str, Any]:
        """Return the section as plain data."""
        return SECTION.write(dataclasses.asdict(self))

    @property
    def bias_sd_total_m(self) -> tuple[float, ...]:
        """Return the SD of a run's bias per axis, both parts together."""
        held = (0.0, 0.0) if self.run_bias_sd_m is None else self.run_bias_sd_m
        return tuple(math.hypot(b, c) for b, c in zip(self.bias_sd_m, held))

    def persistence(self, rate_hz: float = 1.0) -> float:
        """Return the bias's factor per model step, ``a`` (1.0: constant for the run)."""
        if self.bias_time_constant_s is None:
            return 1.0
        return math.exp(-1.0 / (self.bias_time_constant_s * rate_hz))


def population_from_dict(raw: Any, source: str = '<profile>') -> Population:
    """Validate a ``population`` mapping; return :class:`Population`."""
    return Population(**SECTION.read(raw, source))


def agent_scales(keys: Keys, scale_sd_log: float) -> FloatArray:
    """Return each agent's scale ``f`` (n,), from its stream at position 0."""
    keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
    if scale_sd_log == 0.0:
        return np.ones(keys.size)
    z = streams.normal_pairs(keys, streams.DOMAIN_POPULATION_SCALE, 0)[:, 0]
    return np.exp(scale_sd_log * z - scale_sd_log ** 2)


def bias_factors(keys: Keys, start: int, dof: Optional[int]) -> FloatArray:
    """
    Return each run's Student-t factor ``g = sqrt((dof - 2) / chi2)`` (n,); ones without ``dof``.

    ``chi2`` is the sum of ``dof`` squared normals of the ``bias_mix``
    stream at the start step's initial-state positions.
    """
    keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
    if dof is None:
        return np.ones(keys.size)
    chi2 = np.zeros(keys.size)
    for slot in range((dof + 1) // 2):
        z = streams.normal_pairs(keys, streams.DOMAIN_BIAS_MIX,
                                 streams.init_position(start, slot))
        chi2 += z[:, 0] ** 2
        if 2 * slot + 1 < dof:
            chi2 += z[:, 1] ** 2
    return np.sqrt((dof - 2) / chi2)


class AgentDraws:
    """
    What a population section draws for each agent: its scale, its run's bias and wander.

    What :class:`WithPopulation` draws; with a zone map it wraps the zones
    (:class:`~gps_error_ros.model.zoned.WithZones`), so that an agent's bias
    and scale are the same numbers in every zone and without a map.
    """

    def __init__(self, population: Population, rate_hz: float = 1.0) -> None:
        self.population = population
        self.bias_sd = np.asarray(population.bias_sd_m, dtype=float)
        self.a = population.persistence(rate_hz)
        self.wander_sd = self.bias_sd * math.sqrt(max(0.0, 1.0 - self.a * self.a))
        self.held = population.run_bias_sd_m is not None
        self.run_sd = np.asarray(population.run_bias_sd_m if self.held else (0.0, 0.0),
                                 dtype=float)
        #: The population's spread of biases about the mean, (2, 2).
        self.spread = np.diag(self.bias_sd ** 2 + self.run_sd ** 2)

    def scales(self, keys: Keys) -> FloatArray:
        """Return each agent's scale ``f`` (n,)."""
        return agent_scales(keys, self.population.scale_sd_log)

    def run_bias(self, keys: Keys, start: int) -> tuple[FloatArray, FloatArray]:
        """Return the biases (n, 2) runs started at ``start`` draw, and their factors ``g``."""
        g = bias_factors(keys, start, self.population.bias_dof)
        return self.bias_sd * g[:, None] * streams.normal_pairs(
            keys, streams.DOMAIN_INIT_BIAS, start), g

    def held_part(self, keys: Keys, start: int, g: FloatArray) -> FloatArray:
        """Return the parts (n, 2) of the biases held for runs started at ``start``."""
        if not self.held:
            return np.zeros((np.size(keys), 2))
        return self.run_sd * g[:, None] * streams.normal_pairs(
            keys, streams.DOMAIN_RUN_BIAS, start)

    def wander(self, bias: FloatArray, g: FloatArray, keys: Keys, index: int) -> None:
        """Advance the biases ``bias`` (n, 2), factors ``g``, in place to model step ``index``."""
        if self.a < 1.0:
            bias *= self.a
            bias += self.wander_sd * g[:, None] * streams.normal_pairs(
                keys, streams.DOMAIN_BIAS, index)

    def bias_at(self, keys: Keys, start: int, step: int) -> tuple[FloatArray, FloatArray]:
        """Return the biases (n, 2) of runs started at ``start``, at ``step``, and ``g``."""
        bias, g = self.run_bias(keys, start)
        for k in range(start + 1, step + 1):
            self.wander(bias, g, keys, k)
        return bias, g

    def agent_cov(self, cov: FloatArray, scale: FloatArray, g: FloatArray,
                  first: bool = False) -> FloatArray:
        """
        Return agents' covariances (n, 2, 2) of the next error from the process's ``cov``.

        ``cov`` is given the process's state a step before; ``scale`` and
        ``g`` are the agents'. Nothing known of the agent (``first``): the
        process's first-step covariance plus the population's bias spread.
        """
        if first:
            return cov + self.spread
        return cov * (scale ** 2)[:, None, None] + \
            (g ** 2)[:, None, None] * np.diag(self.wander_sd ** 2)

    def agent_mean(self, mean: FloatArray, pm: FloatArray, scale: FloatArray, bias: FloatArray,
                   first: bool = False, held: Optional[FloatArray] = None) -> FloatArray:
        """
        Return agents' expected next errors (n, 2) from the process's ``pm``.

        ``mean`` is the process's mean, ``scale`` and ``bias`` (the run's
        wandering bias a step before) the agents', ``held`` the part of
        their bias held for the run (None: none); ``first``: the process's own.
        """
        if first:
            return pm
        out = mean + scale[:, None] * (pm - mean) + self.a * bias
        return out if held is None else out + held


@dataclasses.dataclass(eq=False)
class PopulationState(WrappedState[Inner]):
    """
    The state of :class:`WithPopulation`: the inner model's, and the agent's draws.

    Attributes
    ----------
    inner : state
        The wrapped model's state.
    bias : (n, 2) float
        The run's wandering bias (north, east), metres.
    scale : (n,) float
        The agent's scale ``f``.
    bias_factor : (n,) float
        The run's Student-t factor ``g`` (1 for a normal bias).
    held : (n, 2) float or None
        The part of the bias held for the run (``run_bias_sd_m``; else None).

    """

    bias: FloatArray
    scale: FloatArray
    bias_factor: FloatArray
    held: Optional[FloatArray]


class WithPopulation(Wrapper[PopulationState[Inner], Inner]):
    """
    An error model of one agent drawn from a population (see the module docstring).

    Its state is a :class:`PopulationState`. Errors, moments and covariances
    are the inner model's, turned into the agent's by its scale and bias.
    """

    def __init__(self, inner: ErrorModel[Inner], population: Population,
                 rate_hz: float = 1.0) -> None:
        super().__init__(inner)
        self.population = population
        self.draws = AgentDraws(population, rate_hz)

    # --- moments ---------------------------------------------------------

    @property
    def stationary_cov(self) -> FloatArray:
        """Return the population's covariance about the mean: the process's plus the bias's."""
        return np.asarray(self.inner.stationary_cov) + self.draws.spread

    def autocovariance(self, max_lag: int) -> FloatArray:
        """Return the population's autocovariance at lags 0..max_lag, (max_lag + 1, 2, 2)."""
        decay = self.draws.a ** np.arange(max_lag + 1)
        return self.inner.autocovariance(max_lag) + \
            decay[:, None, None] * np.diag(self.draws.bias_sd ** 2)[None] + \
            np.diag(self.draws.run_sd ** 2)[None]

    # --- state -----------------------------------------------------------

    def _state(self, inner_state: Inner, keys: Keys, start: int, bias: FloatArray,
               g: FloatArray) -> PopulationState[Inner]:
        """Return the state of ``inner_state`` with the run's biases, ``g`` and the scales."""
        held = self.draws.held_part(keys, start, g) if self.draws.held else None
        return PopulationState(inner_state, np.array(bias, dtype=float),
                               self.draws.scales(keys), np.array(g, dtype=float), held)

    def part(self, state: PopulationState[Inner]) -> Inner:
        """Return the wrapped model's state (``inner``)."""
        return state.inner

    def empty_state(self, n: int) -> PopulationState[Inner]:
        """Return the state of ``n`` agents, all zeros."""
        return PopulationState(self.inner.empty_state(n), np.zeros((n, 2)), np.zeros(n),
                               np.zeros(n), np.zeros((n, 2)) if self.draws.held else None)

    def _agent(self, inner_err: FloatArray, state: PopulationState[Inner]) -> FloatArray:
        """Return the agent's errors from the inner model's: ``m + f d + b``."""
        m = self.inner.means(state.inner)
        out = m + state.scale[:, None] * (inner_err - m) + state.bias
        return out if state.held is None else out + state.held

    def initial_state(self, keys: Keys, index: int,
                      inputs: Inputs = None) -> PopulationState[Inner]:
        """Draw the inner state, the run's bias and the agent's scale at step ``index``."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        return self._state(self.inner.initial_state(keys, index, inputs), keys, index,
                           *self.draws.run_bias(keys, index))

    def advance(self, state: PopulationState[Inner], keys: Keys, index: int,
                inputs: Inputs = None) -> FloatArray:
        """Advance in place to model step ``index``; return the agent's errors."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        err = self.inner.advance(state.inner, keys, index, inputs)
        self.draws.wander(state.bias, state.bias_factor, keys, index)
        return self._agent(err, state)

    def errors(self, state: PopulationState[Inner]) -> FloatArray:
        """Return each agent's current north/east errors, (n, 2)."""
        return self._agent(self.inner.errors(state.inner), state)

    def state_after(self, keys: Keys, start: int, step: int,
                    inputs: Inputs = None) -> PopulationState[Inner]:
        """Return the state at model step ``step`` of a run started at ``start``."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        inner = self.inner.state_after(keys, start, step, inputs)
        return self._state(inner, keys, start, *self.draws.bias_at(keys, start, step))

    def simulate(self, keys: Keys, n_steps: int, start: int = 0,
                 out: Optional[FloatArray] = None) -> FloatArray:
        """Return the agents' errors at steps ``start .. start + n_steps - 1``, (n_steps, n, 2)."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        out = self.inner.simulate(keys, n_steps, start=start, out=out)
        if n_steps == 0:
            return out
        m = np.asarray(self.inner.mean, dtype=float)
        scale = self.draws.scales(keys)[:, None]
        bias, g = self.draws.run_bias(keys, start)
        held = self.draws.held_part(keys, start, g) if self.draws.held else None
        for k in range(n_steps):
            if k:
                self.draws.wander(bias, g, keys, start + k)
            out[k] = m + scale * (out[k] - m) + bias
            if held is not None:
                out[k] += held
        return out

    # --- what a consumer is told ------------------------------------------

    def predictive_cov(self, state: PopulationState[Inner], first: bool = False) -> FloatArray:
        """
        Return each agent's covariance (n, 2, 2) of the next error given ``state``.

        ``first`` (nothing known of the agent): the process's first-step
        covariance (its stationary one) plus the population's bias spread,
        the covariance of the law a run's first error is drawn from.
        """
        return self.draws.agent_cov(self.inner.predictive_cov(state.inner, first),
                                    state.scale, state.bias_factor, first)

    def mean_step_cov(self) -> FloatArray:
        """Return the process's mean one-step covariance plus the population's bias spread."""
        return np.asarray(self.inner.mean_step_cov()) + self.draws.spread

    def predictive_mean(self, state: PopulationState[Inner], first: bool = False) -> FloatArray:
        """Return each agent's expected next error (n, 2) given ``state``, mean included."""
        return self.draws.agent_mean(self.inner.means(state.inner),
                                     self.inner.predictive_mean(state.inner, first),
                                     state.scale, state.bias, first, state.held)

"""
What an error model is: the one protocol every model and wrapper implements.

The package's error processes (:class:`~.ar_model.ARErrorModel`,
:class:`~.effects.ExtendedModel`) and the wrappers around them
(:class:`~.population.WithPopulation`, :class:`~.failures.WithFailures`,
:class:`~.availability.WithAvailability`, :class:`~.about_truth.AboutTruth`)
are all an :class:`ErrorModel`: the node, ``simulate``, the shards and the
judges call only these members, so any of them (or a model of your own)
serves in any place. The type checker holds every class to it.

A model keeps nothing per agent itself: the agents' state is a value
(:mod:`.state`) the caller holds and passes in, created by
:meth:`ErrorModel.initial_state` (or :meth:`ErrorModel.empty_state`) and
changed in place by :meth:`ErrorModel.advance`. Draws come from the agents'
counter-based streams (:mod:`.streams`), keyed by agent and indexed by model
step, so an agent's errors depend on neither how many agents step together
nor, beyond the last bits, when its state was made: a state drawn at a step
and one stepped there from an earlier step differ by about 1e-14 m.

Units: metres, axes (north, east); covariances (2, 2) per agent; keys are
the agents' stream keys (uint64, :func:`~.streams.agent_keys`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Generic, Optional, overload, Protocol, TypeVar, cast

import numpy as np

from gps_error_ros.model.state import AgentState, BoolArray, FloatArray, IntArray

S = TypeVar('S', bound=AgentState)


@dataclass(frozen=True)
class StepInputs:
    """
    What a step may need from the truth: the direction of travel and the zone.

    Attributes
    ----------
    heading : (n,) float or None
        Each agent's direction of travel, radians from north, clockwise
        (NaN: standing, the last direction holds); for ``street_frame``.
    zone : (n,) int or None
        Each agent's zone in a zone map (``zones.OUTSIDE``, -1: the default
        profile's); for :class:`~.zoned.WithZones`.

    Notes
    -----
    A model that needs neither (:attr:`ErrorModel.needs_heading` False, no
    zone map) gives the same errors with inputs or without.

    """

    heading: Optional[FloatArray] = None
    zone: Optional[IntArray] = None

    def take(self, rows: Any) -> 'StepInputs':
        """Return the inputs of agents ``rows`` (an index or mask)."""
        return StepInputs(None if self.heading is None else np.asarray(self.heading)[rows],
                          None if self.zone is None else np.asarray(self.zone)[rows])


#: What a step's ``inputs`` argument takes: :class:`StepInputs`, or None (nothing known).
Inputs = Optional[StepInputs]


class ErrorModel(Protocol[S]):
    """The members every error model and wrapper has (see the module docstring)."""

    @property
    def order(self) -> int:
        """Return the AR order of the process (how many past errors its state holds)."""
        ...

    @property
    def mean(self) -> FloatArray:
        """Return the stationary mean of the error (north, east), metres."""
        ...

    @property
    def lag_s(self) -> float:
        """Return the motion lag, seconds (0: none; applied by the caller, who has the truth)."""
        ...

    @property
    def needs_heading(self) -> bool:
        """Return True when the innovations turn with the direction of travel (street_frame)."""
        ...

    @property
    def stationary_cov(self) -> FloatArray:
        """Return the stationary covariance (2, 2) of the error about its mean."""
        ...

    @property
    def stationary_sd(self) -> FloatArray:
        """Return the stationary standard deviation per axis (north, east)."""
        ...

    def autocovariance(self, max_lag: int) -> FloatArray:
        """Return the exact autocovariance at lags 0..max_lag, (max_lag + 1, 2, 2)."""
        ...

    def autocorrelation(self, max_lag: int) -> FloatArray:
        """Return the exact autocorrelation per axis, (max_lag + 1, 2)."""
        ...

    def mean_step_cov(self) -> FloatArray:
        """Return the one-step covariance averaged over the stationary law (2, 2)."""
        ...

    def empty_state(self, n: int) -> S:
        """Return the state of ``n`` agents, all zeros (slots to be filled)."""
        ...

    def initial_state(self, keys: Any, index: int, inputs: Inputs = None) -> S:
        """Draw the agents' state at model step ``index`` from the stationary law."""
        ...

    def state_after(self, keys: Any, start: int, step: int, inputs: Inputs = None) -> S:
        """Return the state at ``step`` of a run started at ``start``, ``inputs`` at every step."""
        ...

    def prepare(self, state: S, keys: Any, index: int, inputs: Inputs = None) -> None:
        """
        Apply step ``index``'s inputs to ``state`` in place, before its draws.

        The direction of travel turns, an agent entering a zone takes the
        zone's process: what the covariance of the step's error given the
        state depends on. :meth:`advance` applies them too (once: a second
        call changes nothing).
        """
        ...

    def advance(self, state: S, keys: Any, index: int, inputs: Inputs = None) -> FloatArray:
        """
        Advance ``state`` in place to model step ``index``; return the errors (n, 2).

        The one step of the package: every path (the node's engine, crowds,
        ``simulate``, the API, the judges' simulations) advances a model
        through it (see :mod:`.stepping`).
        """
        ...

    def errors(self, state: S) -> FloatArray:
        """Return the current north/east error of every agent (n, 2), mean included."""
        ...

    def means(self, state: S) -> FloatArray:
        """Return the stationary mean (n, 2) of the process each agent is under now."""
        ...

    def fix_mask(self, state: S) -> BoolArray:
        """Return which agents have a fix at the current step (n,) (availability)."""
        ...

    def failed(self, state: S) -> BoolArray:
        """Return which agents' fixes failed at the current step (n,) (gross failures)."""
        ...

    @property
    def has_outages(self) -> bool:
        """Return True when some steps may have no fix (an availability process)."""
        ...

    def simulate_fix(self, keys: Any, n_steps: int, start: int = 0) -> BoolArray:
        """Return the fix mask at steps ``start .. start + n_steps - 1``, (n, n_steps)."""
        ...

    def predictive_cov(self, state: S, first: bool = False) -> FloatArray:
        """
        Return each agent's covariance (n, 2, 2) of its next error given ``state``.

        ``first``: of a run's first error, drawn from the stationary law (the
        covariance of that law, nothing before it being known).
        """
        ...

    def predictive_mean(self, state: S, first: bool = False) -> FloatArray:
        """Return each agent's expected next error (n, 2) given ``state`` (``first``: as above)."""
        ...

    def simulate(self, keys: Any, n_steps: int, start: int = 0,
                 out: Optional[FloatArray] = None) -> FloatArray:
        """Return errors at model steps ``start .. start + n_steps - 1``, (n_steps, n, 2)."""
        ...


class ZoneProcess(ErrorModel[S], Protocol):
    """An error process a zone may have: it hands its AR errors on and takes them over."""

    def carried(self, state: S) -> FloatArray:
        """Return the AR part's last ``p`` errors (n, 2, p), mean included, newest first."""
        ...

    def resumed(self, carried: FloatArray, keys: Any, index: int,
                inputs: Inputs = None) -> S:
        """Return the state of agents entering at step ``index`` with errors ``carried``."""
        ...


class Process(Generic[S]):
    """
    What an error process (not a wrapper) answers of availability and failures: none.

    :class:`~.ar_model.ARErrorModel`, :class:`~.effects.ExtendedModel` and
    :class:`~.zoned.WithZones` take these; the wrappers of
    :mod:`.availability` and :mod:`.failures` answer for their own.
    """

    mean: FloatArray
    #: A process alone has a fix at every step.
    has_outages = False

    def means(self, state: S) -> FloatArray:
        """Return the stationary mean of every agent, (n, 2)."""
        return np.repeat(np.asarray(self.mean)[None], len(state), axis=0)

    def fix_mask(self, state: S) -> BoolArray:
        """Return True for every agent: a process alone has no outages."""
        return np.ones(len(state), dtype=bool)

    def failed(self, state: S) -> BoolArray:
        """Return False for every agent: a process alone has no gross failures."""
        return np.zeros(len(state), dtype=bool)

    def simulate_fix(self, keys: Any, n_steps: int, start: int = 0) -> BoolArray:
        """Return True at every step, (n, n_steps): a process alone has no outages."""
        return np.ones((np.size(keys), n_steps), dtype=bool)


#: A model whose state class is chosen at run time: a profile's chain of
#: wrappers (:meth:`~.profiles.Profile.model`). Its states are known to the
#: type checker only as :class:`~.state.AgentState`.
OpaqueModel = ErrorModel[AgentState]
#: An error process chosen at run time (:func:`~.effects.build_model`: the AR
#: process, with effects or without), as a zone takes it.
OpaqueProcess = ZoneProcess[AgentState]


@overload
def opaque(model: ZoneProcess[S]) -> OpaqueProcess: ...


@overload
def opaque(model: ErrorModel[S]) -> OpaqueModel: ...


def opaque(model: ErrorModel[S]) -> OpaqueModel:
    """
    Return ``model`` typed as an :data:`OpaqueModel` (the same object).

    Which wrappers a profile's model has is read from the profile at run
    time, so no one static type names its state class, and Python's types
    cannot say "some one state class S, with a model of S". This is the one
    place the package forgets S. It stays sound by one rule every holder
    keeps (:class:`~.stepping.StepsPerFix`, the node's engine, the crowd):
    a state goes back only to the model that made it, which holds them
    together. Everything after the choice is typed: a wrapper is generic in
    its inner model's state (:class:`~.state.WrappedState`), and the paths
    that step a model are generic in ``S``.
    """
    return cast('OpaqueModel', model)

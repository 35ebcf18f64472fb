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
nor when its state was made.

Units: metres, axes (north, east); covariances (2, 2) per agent; keys are
the agents' stream keys (uint64, :func:`~.streams.agent_keys`).
"""

from __future__ import annotations

from typing import Any, Optional, Protocol, TypeVar

from gps_error_ros.model.state import AgentState, FloatArray

S = TypeVar('S', bound=AgentState)


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

    def initial_state(self, keys: Any, index: int) -> S:
        """Draw the agents' state at model step ``index`` from the stationary law."""
        ...

    def state_after(self, keys: Any, start: int, step: int,
                    heading: Optional[FloatArray] = None) -> S:
        """Return the state at model step ``step`` of a run started at ``start``."""
        ...

    def advance(self, state: S, keys: Any, index: int,
                heading: Optional[FloatArray] = None) -> FloatArray:
        """Advance ``state`` in place to model step ``index``; return the errors (n, 2)."""
        ...

    def errors(self, state: S) -> FloatArray:
        """Return the current north/east error of every agent (n, 2), mean included."""
        ...

    def face(self, state: S, heading: Any) -> None:
        """Set the agents' direction of travel (radians from north; NaN: the last holds)."""
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

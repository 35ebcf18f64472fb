"""
A model wrapped around another: the base of the wrappers.

:class:`~.population.WithPopulation` (an agent's bias and scale),
:class:`~.failures.WithFailures` (this step's failure),
:class:`~.availability.WithAvailability` (the outage state) and
:class:`~.about_truth.AboutTruth` (covariances about the truth) each wrap
an :class:`~.protocol.ErrorModel` and are one. :class:`Wrapper` holds once
what they share: every member of the protocol, passed to the inner model
with its part of the state (:meth:`Wrapper.part`), so that a wrapper
writes only what it changes. A wrapper with state of its own keeps the
inner model's state whole as the ``inner`` field of its own state class
(:mod:`.state`), so a wrapper is generic in two state classes: its own
(``W``) and its inner model's (``Inner``).
"""

from __future__ import annotations

from typing import Any, Generic, Optional, TypeVar

import numpy as np

from gps_error_ros.model.protocol import ErrorModel, Inputs
from gps_error_ros.model.state import AgentState, BoolArray, FloatArray, Inner

#: The wrapper's own state class.
W = TypeVar('W', bound=AgentState)


class Wrapper(Generic[W, Inner]):
    """An :class:`~.protocol.ErrorModel` made from ``inner``: every member passed on."""

    def __init__(self, inner: ErrorModel[Inner]) -> None:
        self.inner = inner

    # --- what a wrapper with state of its own overrides -------------------

    def part(self, state: W) -> Inner:
        """Return the inner model's part of ``state`` (its ``inner`` field)."""
        raise NotImplementedError

    def empty_state(self, n: int) -> W:
        """Return the state of ``n`` agents, all zeros."""
        raise NotImplementedError

    def initial_state(self, keys: Any, index: int, inputs: Inputs = None) -> W:
        """Draw the state at model step ``index``."""
        raise NotImplementedError

    def state_after(self, keys: Any, start: int, step: int, inputs: Inputs = None) -> W:
        """Return the state at model step ``step`` of a run started at ``start``."""
        raise NotImplementedError

    def advance(self, state: W, keys: Any, index: int, inputs: Inputs = None) -> FloatArray:
        """Advance ``state`` in place to model step ``index``; return the errors (n, 2)."""
        raise NotImplementedError

    # --- passed on ----------------------------------------------------------

    @property
    def order(self) -> int:
        """Return the AR order of the process beneath."""
        return self.inner.order

    @property
    def mean(self) -> FloatArray:
        """Return the stationary mean of the process beneath, north and east."""
        return self.inner.mean

    @property
    def lag_s(self) -> float:
        """Return the motion lag, seconds."""
        return self.inner.lag_s

    @property
    def needs_heading(self) -> bool:
        """Return True when the innovations turn with the direction of travel."""
        return self.inner.needs_heading

    @property
    def stationary_cov(self) -> FloatArray:
        """Return the stationary covariance (2, 2)."""
        return self.inner.stationary_cov

    @property
    def stationary_sd(self) -> FloatArray:
        """Return the stationary standard deviation per axis."""
        return np.sqrt(np.diag(self.stationary_cov))

    def autocovariance(self, max_lag: int) -> FloatArray:
        """Return the autocovariance at lags 0..max_lag, (max_lag + 1, 2, 2)."""
        return self.inner.autocovariance(max_lag)

    def autocorrelation(self, max_lag: int) -> FloatArray:
        """Return the autocorrelation per axis, (max_lag + 1, 2)."""
        acv = self.autocovariance(max_lag)
        diag = np.stack([acv[:, 0, 0], acv[:, 1, 1]], axis=1)
        return diag / diag[0]

    def mean_step_cov(self) -> FloatArray:
        """Return the one-step covariance averaged over the stationary law (2, 2)."""
        return self.inner.mean_step_cov()

    def errors(self, state: W) -> FloatArray:
        """Return the current north/east errors, (n, 2)."""
        return self.inner.errors(self.part(state))

    def prepare(self, state: W, keys: Any, index: int, inputs: Inputs = None) -> None:
        """Apply step ``index``'s inputs to the inner model's state."""
        self.inner.prepare(self.part(state), keys, index, inputs)

    def means(self, state: W) -> FloatArray:
        """Return the stationary mean (n, 2) of the process each agent is under."""
        return self.inner.means(self.part(state))

    def fix_mask(self, state: W) -> BoolArray:
        """Return which agents have a fix now (the inner model's)."""
        return self.inner.fix_mask(self.part(state))

    def failed(self, state: W) -> BoolArray:
        """Return which agents' fixes failed now (the inner model's)."""
        return self.inner.failed(self.part(state))

    @property
    def has_outages(self) -> bool:
        """Return True when some steps may have no fix (the inner model's)."""
        return self.inner.has_outages

    def simulate_fix(self, keys: Any, n_steps: int, start: int = 0) -> BoolArray:
        """Return the fix mask at steps ``start ..``, (n, n_steps) (the inner model's)."""
        return self.inner.simulate_fix(keys, n_steps, start)

    def predictive_cov(self, state: W, first: bool = False) -> FloatArray:
        """Return each agent's covariance of the next error given ``state`` (n, 2, 2)."""
        return self.inner.predictive_cov(self.part(state), first)

    def predictive_mean(self, state: W, first: bool = False) -> FloatArray:
        """Return each agent's expected next error given ``state`` (n, 2)."""
        return self.inner.predictive_mean(self.part(state), first)

    def simulate(self, keys: Any, n_steps: int, start: int = 0,
                 out: Optional[FloatArray] = None) -> FloatArray:
        """Return errors at model steps ``start .. start + n_steps - 1``, (n_steps, n, 2)."""
        return self.inner.simulate(keys, n_steps, start=start, out=out)

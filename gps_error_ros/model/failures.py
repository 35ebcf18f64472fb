"""
Gross failures in simulation: a fix that is not an estimate of the position.

A profile's optional ``gross_failures`` section (``gps_error calibrate``
writes it when a recording had some; the rule that finds them is in
:mod:`gps_error_ros.fit.gross_failures`)::

    gross_failures:
      rate: 0.012            # per model step, the chance that the fix failed
      sizes_m: [40, 62, 95, 180, 820, 24000]   # distance from the truth, m: quantiles
      rate_sd_log: 0.9       # optional: each agent fails at a rate of its own

At each model step, independently, the fix fails with probability ``rate``.
With ``rate_sd_log`` (``s``) that probability is the agent's own,
``rate * exp(s z - s^2 / 2)`` with ``z`` standard normal (at most
:data:`MAX_AGENT_RATE`): receivers, and the ways they are carried, differ in
how often they fail far more than one rate gives, and the mean over agents
is still ``rate``.
A failed fix lies at a distance drawn from ``sizes_m`` (quantiles at evenly
spaced probabilities from 0 to 1, interpolated in the logarithm of the
distance) in a direction uniform on the circle, from the truth: it replaces
the error of that step. The error process runs on beneath it (a failed
solution does not move the receiver's state), so the next step's error is
what it would have been.

Draws: the failure's and its size's uniforms from the stream domain
``failure``, the direction's from ``failure_direction``, one pair each per
model step; the agent's own rate's normal from ``failure_rate`` at position
0 (a receiver keeps its rate whenever it starts). They depend on nothing but
(seed, agent, step), so an agent's failures are the same alone, in a crowd,
in a shard, whenever it started.

The published covariance does not cover a failure (a receiver does not know
that its solution failed); the section leaves a profile's covariance as it
was.
"""

import dataclasses
from dataclasses import dataclass
import math
from typing import Any, Optional, Sequence

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.protocol import ErrorModel, Inputs
from gps_error_ros.model.section_spec import Field, SectionSpec
from gps_error_ros.model.state import BoolArray, FloatArray, Inner, Keys, Numbers, WrappedState
from gps_error_ros.model.wrapped import Wrapper

#: The largest failure distance a profile may carry, m (a fix on the wrong continent).
MAX_SIZE_M = 2.0e7
#: The smallest a fitted failure distance is written, m.
MIN_SIZE_M = 1e-3
#: The largest SD of the log of an agent's rate (a factor of e^3 between agents at 1 SD).
MAX_RATE_SD_LOG = 3.0
#: The largest rate an agent may draw (its failures are still a minority of its fixes).
MAX_AGENT_RATE = 0.5
#: Nodes of the normal ``z`` of an agent's log rate, evenly over +-6 SD, for the count's law.
_RATE_NODES = 241


def rate_of(rate: float, rate_sd_log: float, z: Numbers) -> FloatArray:
    """Return the rates of agents whose log-rate normals are ``z``: the section's law."""
    s = rate_sd_log
    return np.minimum(rate * np.exp(s * np.asarray(z) - 0.5 * s * s), MAX_AGENT_RATE)


def rate_nodes(nodes: int = _RATE_NODES) -> tuple[FloatArray, FloatArray]:
    """Return (``z``, log weights) of the standard normal on an even grid over +-6 SD."""
    z = np.linspace(-6.0, 6.0, nodes)
    log_w = -0.5 * z * z
    return z, log_w - np.logaddexp.reduce(log_w)


class FailuresError(ValueError):
    """A ``gross_failures`` section that is not valid."""


#: The ``gross_failures`` section, field by field.
SECTION = SectionSpec('gross_failures', (
    Field('rate', 'per model step, the chance that the fix failed', lo=0.0, hi=1.0,
          hi_open=True, digits=8),
    Field('sizes_m', 'distance of a failed fix from the truth (m): quantiles at evenly '
          'spaced probabilities', kind='sizes', lo=0.0, hi=MAX_SIZE_M, lo_open=True, digits=3),
    Field('rate_sd_log', 'SD of the log of each agent\'s own rate', lo=0.0,
          hi=MAX_RATE_SD_LOG, absent='one rate for every agent', digits=4),
), FailuresError)


@dataclass(frozen=True)
class GrossFailureProcess:
    """The parsed section (see the module docstring)."""

    rate: float
    sizes_m: tuple[float, ...]
    rate_sd_log: Optional[float] = None

    def to_dict(self) -> dict[str, Any]:
        """Return the section as plain data."""
        return SECTION.write(dataclasses.asdict(self))

    def agent_rates(self, keys: Keys) -> FloatArray:
        """Return each agent's rate (n,): ``rate`` for all without ``rate_sd_log``."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        if not self.rate_sd_log:
            return np.full(keys.size, self.rate)
        z = streams.normal_pairs(keys, streams.DOMAIN_FAILURE_RATE, 0)[:, 0]
        return rate_of(self.rate, self.rate_sd_log, z)

    def count_law(self, fixes: int) -> FloatArray:
        """
        Return the probabilities of 0..``fixes`` failures among one agent's ``fixes`` fixes.

        Binomial at ``rate``; with ``rate_sd_log``, averaged over the
        agents' rates (the normal ``z`` on a fine grid: one agent's count
        pins its rate more finely than a few quadrature nodes resolve).
        """
        from scipy import stats
        counts = np.arange(int(fixes) + 1)
        if not self.rate_sd_log:
            return stats.binom.pmf(counts, int(fixes), self.rate)
        z, log_w = rate_nodes()
        law = np.zeros(counts.size)
        for r, weight in zip(rate_of(self.rate, self.rate_sd_log, z), np.exp(log_w)):
            law += weight * stats.binom.pmf(counts, int(fixes), r)
        return law / law.sum()

    def count_range(self, fixes: int | Sequence[int],
                    level: float = 0.95) -> tuple[int, int]:
        """
        Return the central ``level`` range (lo, hi) of failures among ``fixes``.

        ``fixes``: one agent's number of fixes, or a sequence of them (several
        agents, each with its own rate: the range of their total).
        """
        from scipy import signal
        law = np.ones(1)
        for n in np.atleast_1d(fixes):
            law = np.clip(signal.fftconvolve(law, self.count_law(n)), 0.0, None)
        cdf = np.cumsum(law) / law.sum()
        tail = 0.5 * (1.0 - level)
        return (int(np.searchsorted(cdf, tail)),
                min(int(np.searchsorted(cdf, 1.0 - tail)), law.size - 1))

    def count_tail(self, count: int, fixes: int) -> float:
        """Return the probability of a count as far as ``count`` or further on its side."""
        law = self.count_law(fixes)
        mean = float(np.arange(law.size) @ law)
        return float(min(1.0, law[count:].sum() if count >= mean else law[:count + 1].sum()))

    def offsets(self, keys: Keys, index: int) -> tuple[FloatArray, BoolArray]:
        """
        Return the failures of model step ``index``: (n, 2) north/east m and a mask.

        The offsets are zero where the fix did not fail.
        """
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        u = streams.uniform_pairs(keys, streams.DOMAIN_FAILURE, index)
        fails = u[:, 0] < (self.agent_rates(keys) if self.rate_sd_log else self.rate)
        out = np.zeros((keys.size, 2))
        if fails.any():
            sizes = np.asarray(self.sizes_m, dtype=float)
            if sizes.size == 1:
                r = np.full(int(fails.sum()), sizes[0])
            else:
                r = np.exp(np.interp(u[fails, 1], np.linspace(0.0, 1.0, sizes.size),
                                     np.log(sizes)))
            theta = 2.0 * math.pi * streams.uniform_pairs(
                keys[fails], streams.DOMAIN_FAILURE_DIRECTION, index)[:, 0]
            out[fails, 0] = r * np.cos(theta)
            out[fails, 1] = r * np.sin(theta)
        return out, fails


def failures_from_dict(raw: Any, source: str = '<profile>') -> GrossFailureProcess:
    """Validate a ``gross_failures`` mapping; return :class:`GrossFailureProcess`."""
    return GrossFailureProcess(**SECTION.read(raw, source))


def failures_from_sizes(count: int, fixes: int, sizes_m: Numbers, quantiles: int = 11,
                        spread: Optional[tuple[float, Optional[float]]] = None
                        ) -> Optional[GrossFailureProcess]:
    """
    Return the section fitted from failures found, or None when there were none.

    ``rate`` is ``count / fixes`` (maximum likelihood) or, with ``spread``
    (``(rate, rate_sd_log)`` fitted from the recordings' counts), that
    rate and its spread between agents; ``sizes_m`` the
    found distances' quantiles at ``quantiles`` evenly spaced probabilities
    (all of them, sorted, when fewer), at least 1 mm (a fix far from the
    recording's median error can lie on the truth itself).
    """
    if count == 0 or fixes == 0:
        return None
    sizes = np.clip(np.sort(np.asarray(sizes_m, dtype=float)), MIN_SIZE_M, MAX_SIZE_M)
    if sizes.size > quantiles:
        sizes = np.exp(np.quantile(np.log(sizes), np.linspace(0.0, 1.0, quantiles)))
    sizes = tuple(float(v) for v in sizes)
    if spread is not None and spread[1] is not None:
        return GrossFailureProcess(float(spread[0]), sizes, float(spread[1]))
    return GrossFailureProcess(count / fixes, sizes)


@dataclasses.dataclass(eq=False)
class FailureState(WrappedState[Inner]):
    """
    The state of :class:`WithFailures`: the inner model's, and this step's failure.

    ``inner`` the wrapped model's state; ``offset`` (n, 2) this step's
    failure offset, metres (north, east; zero: no failure).
    """

    offset: FloatArray


class WithFailures(Wrapper[FailureState[Inner], Inner]):
    """
    An error model with gross failures: the inner model's errors, replaced where a fix failed.

    Its state is a :class:`FailureState`. Everything else, the covariances
    too (they do not cover failures), is the inner model's
    (:class:`~.wrapped.Wrapper`).
    """

    def __init__(self, inner: ErrorModel[Inner], failures: GrossFailureProcess) -> None:
        super().__init__(inner)
        self.failures = failures

    def part(self, state: FailureState[Inner]) -> Inner:
        """Return the wrapped model's state (``inner``)."""
        return state.inner

    def empty_state(self, n: int) -> FailureState[Inner]:
        """Return the state of ``n`` agents, all zeros."""
        return FailureState(self.inner.empty_state(n), np.zeros((n, 2)))

    def initial_state(self, keys: Keys, index: int, inputs: Inputs = None) -> FailureState[Inner]:
        """Draw the inner state and this step's failure at model step ``index``."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        return FailureState(self.inner.initial_state(keys, index, inputs),
                            self.failures.offsets(keys, index)[0])

    def advance(self, state: FailureState[Inner], keys: Keys, index: int,
                inputs: Inputs = None) -> FloatArray:
        """Advance in place to model step ``index``; return the errors."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        err = self.inner.advance(state.inner, keys, index, inputs)
        off, fails = self.failures.offsets(keys, index)
        state.offset[:] = off
        return np.where(fails[:, None], off, err)

    def failed(self, state: FailureState[Inner]) -> BoolArray:
        """Return which agents' fixes failed at the current step."""
        return np.any(state.offset != 0.0, axis=1) | self.inner.failed(state.inner)

    def errors(self, state: FailureState[Inner]) -> FloatArray:
        """Return the current north/east errors, a failed fix's where one failed."""
        err = self.inner.errors(state.inner)
        off = state.offset
        return np.where(np.any(off != 0.0, axis=1)[:, None], off, err)

    def state_after(self, keys: Keys, start: int, step: int,
                    inputs: Inputs = None) -> FailureState[Inner]:
        """Return the state at model step ``step`` of a run started at ``start``."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        return FailureState(self.inner.state_after(keys, start, step, inputs),
                            self.failures.offsets(keys, step)[0])

    def simulate(self, keys: Keys, n_steps: int, start: int = 0,
                 out: Optional[FloatArray] = None) -> FloatArray:
        """Return the inner model's simulation with the failures in, (n_steps, n, 2)."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        out = self.inner.simulate(keys, n_steps, start=start, out=out)
        for k in range(n_steps):
            off, fails = self.failures.offsets(keys, start + k)
            if fails.any():
                out[k, fails] = off[fails]
        return out

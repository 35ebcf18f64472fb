"""
Fix availability: when an agent's phone has no fix, from its own stream.

A profile's optional ``availability`` section::

    availability:
      outage_rate: 0.002         # per step with a fix: probability an outage begins
      durations: [[2, 0.5], [10, 0.3], [60, 0.2]]   # outage length (model steps), probability

The process is semi-Markov with two states, per agent, on the model grid. At
each step that follows a step with a fix, an outage begins with probability
``outage_rate`` (a uniform of the stream domain ``outage`` at that step);
its length ``L`` (steps, at least 1) is drawn from the empirical
distribution ``durations`` (the pair's second uniform). Steps ``k .. k+L-1``
have no fix; step ``k+L`` has one (an outage is never followed directly by
another). The fixes between outages are therefore 1 + a geometric number of
steps, mean ``1 / outage_rate``, and the long-run fraction of steps without
a fix is ``E[L] / (E[L] + 1 / outage_rate)``.

At a run's first step the state is drawn from that stationary law (a
uniform of the domain ``init_outage``): no fix with the outage fraction, and
then the steps left from the residual-length law ``P(R = j) = P(L >= j) /
E[L]``. Everything is a pure function of (seed, agent, step), as the errors.

The error process runs on through an outage (a receiver's error state is not
reset by losing the fix); :class:`WithAvailability` adds the outage state to
any error model without touching its errors: a profile without this section
gives the same errors, bit for bit, as before it existed.
"""

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.protocol import ErrorModel, Inputs
from gps_error_ros.model.section_spec import Field, SectionSpec
from gps_error_ros.model.state import BoolArray, FloatArray, Inner, Keys, Numbers, WrappedState
from gps_error_ros.model.wrapped import Wrapper


class AvailabilityError(ValueError):
    """An ``availability`` section that is not valid."""


#: The ``availability`` section, field by field (read, written and documented from here).
SECTION = SectionSpec('availability', (
    Field('outage_rate', 'the chance, per step with a fix, that an outage begins', 'number',
          0.0, 1.0, hi_open=True),
    Field('durations', 'the outages\' lengths (model steps) and their probabilities, '
          'each length once, the probabilities summing to 1', 'distribution', 1.0),
), AvailabilityError)


@dataclass(frozen=True)
class Availability:
    """Outage process parameters (see module doc)."""

    outage_rate: float
    lengths: tuple[int, ...]     # outage lengths, model steps (ints >= 1), increasing
    probs: tuple[float, ...]     # their probabilities (sum 1)

    @property
    def mean_length(self) -> float:
        """Return the mean outage length, steps."""
        return float(np.dot(self.lengths, self.probs))

    @property
    def outage_fraction(self) -> float:
        """Return the long-run fraction of steps without a fix."""
        if self.outage_rate <= 0:
            return 0.0
        m = self.mean_length
        return m / (m + 1.0 / self.outage_rate)

    def to_dict(self) -> dict[str, Any]:
        """Return the profile section as plain data."""
        return SECTION.write({'outage_rate': self.outage_rate,
                              'durations': list(zip(self.lengths, self.probs))})

    # --- the process, vectorised over agents ------------------------------

    def _length(self, u: FloatArray) -> FloatArray:
        cum = np.cumsum(self.probs)
        cum[-1] = 1.0
        idx = np.minimum(np.searchsorted(cum, u, side='right'), len(self.lengths) - 1)
        return np.asarray(self.lengths, dtype=np.float64)[idx]

    def initial(self, keys: Keys, index: int) -> FloatArray:
        """Return the steps of outage left at step ``index`` (0: a fix), per agent."""
        u = streams.uniform_pairs(keys, streams.DOMAIN_INIT_OUTAGE, index)
        left = np.zeros(u.shape[0])
        out = u[:, 0] < self.outage_fraction
        if out.any():
            lengths = np.asarray(self.lengths)
            # residual law: P(R = j) = P(L >= j) / E[L], j = 1 .. max L
            j = np.arange(1, lengths.max() + 1)
            surv = np.array([np.sum(np.asarray(self.probs)[lengths >= k]) for k in j])
            cum = np.cumsum(surv / surv.sum())
            cum[-1] = 1.0
            left[out] = j[np.minimum(np.searchsorted(cum, u[out, 1], side='right'),
                                     j.size - 1)]
        return left

    def advance(self, left: FloatArray, keys: Keys, index: int) -> BoolArray:
        """Advance ``left`` in place to step ``index``; return the fix mask."""
        u = streams.uniform_pairs(keys, streams.DOMAIN_OUTAGE, index)
        was_fix = left == 0
        left[~was_fix] -= 1
        begins = was_fix & (u[:, 0] < self.outage_rate)
        if begins.any():
            left[begins] = self._length(u[begins, 1])
        return left == 0


def availability_from_dict(raw: Any, source: str = '<profile>') -> Availability:
    """
    Validate an ``availability`` mapping; return :class:`Availability`.

    Each key is checked as :data:`SECTION` declares it; what one field cannot
    say is checked here: each length once, probabilities summing to 1.
    """
    values = SECTION.read(raw, source)
    pairs = values['durations']
    lengths = [n for n, _ in pairs]
    if len(set(lengths)) != len(lengths):
        raise AvailabilityError(f'{source}: key availability.durations: a length appears '
                                f'twice in {lengths}')
    total = sum(p for _, p in pairs)
    if abs(total - 1.0) > 1e-6:
        raise AvailabilityError(f'{source}: key availability.durations: probabilities must '
                                f'sum to 1, got {total!r}')
    order = np.argsort(lengths)
    return Availability(values['outage_rate'], tuple(int(lengths[i]) for i in order),
                        tuple(float(pairs[i][1]) for i in order))


@dataclasses.dataclass(eq=False)
class AvailabilityState(WrappedState[Inner]):
    """
    The state of :class:`WithAvailability`: the inner model's, and the outage's.

    ``inner`` the wrapped model's state; ``outage_left`` (n,) float the
    steps of outage left (0: a fix).
    """

    outage_left: FloatArray


class WithAvailability(Wrapper[AvailabilityState[Inner], Inner]):
    """
    An error model with fix availability: the inner model's errors, unchanged.

    Its state is an :class:`AvailabilityState`; everything but the outage is
    the inner model's (:class:`~.wrapped.Wrapper`).
    """

    def __init__(self, inner: ErrorModel[Inner], availability: Availability) -> None:
        super().__init__(inner)
        self.availability = availability

    def part(self, state: AvailabilityState[Inner]) -> Inner:
        """Return the wrapped model's state (``inner``)."""
        return state.inner

    def empty_state(self, n: int) -> AvailabilityState[Inner]:
        """Return the state of ``n`` agents, all zeros."""
        return AvailabilityState(self.inner.empty_state(n), np.zeros(n))

    def initial_state(self, keys: Keys, index: int,
                      inputs: Inputs = None) -> AvailabilityState[Inner]:
        """Draw the inner state and the outage state at model step ``index``."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        return AvailabilityState(self.inner.initial_state(keys, index, inputs),
                                 np.asarray(self.availability.initial(keys, index), dtype=float))

    def advance(self, state: AvailabilityState[Inner], keys: Keys, index: int,
                inputs: Inputs = None) -> FloatArray:
        """Advance both in place to model step ``index``; return the errors."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        err = self.inner.advance(state.inner, keys, index, inputs)
        self.availability.advance(state.outage_left, keys, index)
        return err

    def fix_mask(self, state: AvailabilityState[Inner]) -> BoolArray:
        """Return which agents have a fix at the current step."""
        return (state.outage_left == 0) & self.inner.fix_mask(state.inner)

    def failed(self, state: AvailabilityState[Inner]) -> BoolArray:
        """Return which agents' fixes failed at the current step: none without a fix."""
        return self.inner.failed(state.inner) & self.fix_mask(state)

    def state_after(self, keys: Keys, start: int, step: int,
                    inputs: Inputs = None) -> AvailabilityState[Inner]:
        """Return the state at model step ``step`` of a run started at ``start``."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        inner = self.inner.state_after(keys, start, step, inputs)
        left = np.asarray(self.availability.initial(keys, start), dtype=float)
        for k in range(start + 1, step + 1):
            self.availability.advance(left, keys, k)
        return AvailabilityState(inner, left)

    #: Some steps have no fix.
    has_outages = True

    def simulate_fix(self, keys: Keys, n_steps: int, start: int = 0) -> BoolArray:
        """Return the fix mask at steps ``start .. start + n_steps - 1``, (n, n_steps)."""
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        left = self.availability.initial(keys, start)
        out = np.empty((keys.size, n_steps), dtype=bool)
        if n_steps:
            out[:, 0] = left == 0
        for i in range(1, n_steps):
            out[:, i] = self.availability.advance(left, keys, start + i)
        return out


def runs_without_fix(mask: Numbers) -> list[int]:
    """Return the lengths of the runs of False in a 1-D fix mask, those at its ends included."""
    mask = np.asarray(mask, dtype=bool)
    edges = np.diff(np.r_[0, (~mask).astype(np.int8), 0])
    return (np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)).tolist()

"""
The one stepping loop: every path advances a model through these functions.

A model's step is :meth:`~.protocol.ErrorModel.advance`. What the paths
around it share is written here once: the covariance a consumer is told
(given the state a step before, taken before the step), a run's start
(:func:`state_at`), a run of every agent over a span (:func:`run`: the API,
the judges' simulations) and agents stepped when their fix is made
(:class:`StepsPerFix`: a model whose step needs the truth, a direction of
travel or a zone, in the node's engine, crowds and ``simulate``). The
node's engine and crowds step every agent each model step with
:func:`step`. So the node, ``simulate`` (CSV, NMEA, FCD), ``add_errors``,
``simulate_errors`` and the judges give one agent the same errors; a test
runs every path on profiles drawn from the whole schema
(``test/model/test_one_step.py``).
"""

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, Optional

import numpy as np

from gps_error_ros.model.protocol import ErrorModel, Inputs, S, StepInputs
from gps_error_ros.model.state import BoolArray, FloatArray, IntArray, Keys, Numbers


def step(model: ErrorModel[S], state: S, keys: Keys, index: int, inputs: Inputs = None,
         cov: bool = False) -> Optional[FloatArray]:
    """
    Advance ``state`` in place to model step ``index``.

    Returns the covariance (n, 2, 2) of the step's error given the state
    before it when ``cov`` (the ``conditional`` covariance mode), else None.
    """
    given = None
    if cov:
        model.prepare(state, keys, index, inputs)      # the covariance of this step's draws
        given = model.predictive_cov(state)
    model.advance(state, keys, index, inputs)
    return given


def state_at(model: ErrorModel[S], keys: Keys, start: int, index: int, inputs: Inputs = None,
             cov: bool = False) -> tuple[S, Optional[FloatArray]]:
    """
    Return the state at step ``index`` of a run from ``start``, and its covariance.

    ``inputs`` hold at every step (an agent caught up from the run's start
    takes the truth of now). The covariance (``cov``) is that of the error
    at ``index`` given the state a step before; at ``start``, of the
    stationary law the run's first error is drawn from.
    """
    if index == start:
        state = model.initial_state(keys, index, inputs)
        return state, model.predictive_cov(state, first=True) if cov else None
    if not cov:
        return model.state_after(keys, start, index, inputs), None
    state = model.state_after(keys, start, index - 1, inputs)
    return state, step(model, state, keys, index, inputs, cov)


@dataclass(frozen=True)
class Run:
    """
    Every agent over a span of model steps, from :func:`run`.

    Attributes
    ----------
    errors : (n, steps, 2) float
        North and east errors, metres (through outages too).
    fix : (n, steps) bool
        Where the agent has a fix (availability).
    failed : (n, steps) bool
        Where the fix failed (gross failures).
    covariance : (n, steps, 2, 2) float or None
        With ``cov``: each error's covariance given the state a step before
        (the first: the stationary law's).

    """

    errors: FloatArray
    fix: BoolArray
    failed: BoolArray
    covariance: Optional[FloatArray]


def run(model: ErrorModel[S], keys: Keys, start: int, steps: int, cov: bool = False,
        inputs: Optional[Callable[[int], Inputs]] = None) -> Run:
    """
    Return every agent's errors at model steps ``start .. start + steps - 1``.

    ``inputs(k)``: the inputs of model step ``k`` (None: none).
    """
    keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
    n = keys.size
    err = np.empty((n, steps, 2))
    fix = np.empty((n, steps), dtype=bool)
    failed = np.empty((n, steps), dtype=bool)
    covariance = np.empty((n, steps, 2, 2)) if cov else None
    state: Optional[S] = None
    for i in range(steps):
        now = None if inputs is None else inputs(start + i)
        if state is None:
            state, given = state_at(model, keys, start, start, now, cov)
        else:
            given = step(model, state, keys, start + i, now, cov)
        if covariance is not None and given is not None:
            covariance[:, i] = given
        err[:, i] = model.errors(state)
        fix[:, i] = model.fix_mask(state)
        failed[:, i] = model.failed(state)
    return Run(err, fix, failed, covariance)


#: Per-slot arrays of :class:`StepsPerFix` beside its state.
_SLOT_ARRAYS = ('step', 'started', 'cov')


class StepsPerFix(Generic[S]):
    """
    Agents (slots) stepped when their fix is made, with the truth's inputs of now.

    A model whose step needs the truth (a street frame's direction of
    travel, a zone map's zone) cannot step when the clock reaches a step:
    the truth for it may come later. Each slot is advanced when its fix is
    made, through the model's own step; steps it got no fix for are taken
    with the inputs of the next fix, and a slot first seen at a later step
    is caught up from the run's start with the inputs of its first fix.
    Given the truth, every error is a pure function of (seed, agent, step):
    the node, ``simulate`` and every shard agree.

    Parameters
    ----------
    model
        The whole model (population, failures and availability included).
    n
        Slots to start with (more with :meth:`grow`).
    conditional_cov
        State each error's covariance given the state a step before (else
        the stationary one of the process the agent is under).

    """

    def __init__(self, model: ErrorModel[S], n: int = 0, conditional_cov: bool = False) -> None:
        self.model = model
        self.conditional_cov = conditional_cov
        #: whether the model's innovations turn with the direction of travel
        self.needs_heading = model.needs_heading
        self.start: Optional[int] = None
        self.state: S = model.empty_state(n)
        self.step = np.zeros(n, dtype=np.int64)        # last model step advanced
        self.started = np.zeros(n, dtype=bool)
        self.cov = np.zeros((n, 2, 2))                 # of the current error, given the last

    @property
    def n(self) -> int:
        """Return the number of slots."""
        return int(self.started.size)

    def grow(self, n: int) -> None:
        """Add ``n`` slots (not started)."""
        self.state = self.state.joined(self.model.empty_state(n))
        self.step = np.concatenate([self.step, np.zeros(n, dtype=np.int64)])
        self.started = np.concatenate([self.started, np.zeros(n, dtype=bool)])
        self.cov = np.concatenate([self.cov, np.zeros((n, 2, 2))])

    def keep(self, mask: BoolArray) -> None:
        """Keep only the slots where ``mask`` is True (in order)."""
        self.state = self.state.take(mask)
        for name in _SLOT_ARRAYS:
            setattr(self, name, getattr(self, name)[mask])

    def restart(self, start: int, rows: Any = slice(None)) -> None:
        """Forget ``rows`` (all by default); runs count from model step ``start``."""
        self.start = int(start)
        self.started[rows] = False

    def forget(self, rows: Any) -> None:
        """Forget ``rows``: their next fix starts them again from the run's start."""
        self.started[rows] = False

    def errors(self, rows: Numbers, keys: Keys, step: int, zones: Optional[Numbers] = None,
               heading: Optional[Numbers] = None) -> tuple[FloatArray, FloatArray]:
        """
        Return the error (m, 2) and covariance (m, 2, 2) of ``rows`` at model step ``step``.

        ``keys`` are the rows' stream keys, ``zones`` each row's zone now
        (``zones.OUTSIDE`` for the default; None: no zone map) and
        ``heading`` the direction of travel now (radians; NaN standing).
        Rows behind are advanced to ``step`` first, with these inputs.
        """
        rows = np.asarray(rows, dtype=np.int64)
        keys = np.asarray(keys, dtype=np.uint64)
        inputs = StepInputs(None if heading is None else np.asarray(heading, dtype=float),
                            None if zones is None else np.asarray(zones, dtype=np.int64))
        self._start()                   # a run's first step must be set
        fresh = ~self.started[rows]
        if fresh.any():
            self._begin(rows[fresh], keys[fresh], step, inputs.take(fresh))
        if np.any(self.step[rows] > step):
            raise ValueError(f'model step {step} is before the last step served '
                             f'({int(self.step[rows].max())})')
        behind = np.flatnonzero(self.step[rows] < step)
        if behind.size:
            self._catch_up(rows[behind], keys[behind], step, inputs.take(behind))
        now = self._rows(rows)
        cov = self.cov[rows] if self.conditional_cov else \
            self.model.predictive_cov(now, first=True)
        return self.model.errors(now), cov

    def _begin(self, rows: IntArray, keys: Keys, index: int, inputs: StepInputs) -> None:
        """Start ``rows`` at ``index``: the state of a run from the start, inputs of now."""
        state, cov = state_at(self.model, keys, self._start(), index, inputs,
                              self.conditional_cov)
        self.state.put(rows, state)
        if cov is not None:
            self.cov[rows] = cov
        self.step[rows] = index
        self.started[rows] = True

    def _catch_up(self, rows: IntArray, keys: Keys, index: int, inputs: StepInputs) -> None:
        """Advance ``rows`` (behind) to model step ``index``, one step at a time."""
        for k in range(int(self.step[rows].min()) + 1, index + 1):
            due = self.step[rows] < k
            r = rows[due]
            part = self._rows(r)
            cov = step(self.model, part, keys[due], k, inputs.take(due), self.conditional_cov)
            if part is not self.state:
                self.state.put(r, part)
            if cov is not None:
                self.cov[r] = cov
            self.step[r] = k

    def _rows(self, rows: IntArray) -> S:
        """
        Return the state of ``rows``: the state itself when they are every slot in order.

        A crowd's fixes usually serve every slot at once; copying every
        zone's state of every agent to step them and back again doubled
        the zone path's cost.
        """
        if rows.size == self.n and np.array_equal(rows, np.arange(self.n)):
            return self.state
        return self.state.take(rows)

    def _start(self) -> int:
        """Return the run's first model step (set by :meth:`restart`)."""
        if self.start is None:
            raise ValueError('StepsPerFix.restart(start) was not called')
        return self.start

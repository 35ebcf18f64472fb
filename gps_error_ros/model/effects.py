"""
Model extensions beyond the paper's AR(p): the ``effects`` of a profile.

A profile's optional ``effects`` section adds any of these effects to the AR
process of :mod:`ar_model` (written by ``gps_error diagnose --profile-out``;
the schema is :mod:`effect_schema`)::

    effects:
      cross_axis_coupling: {innovation_corr: 0.35}
      motion_lag: {lag_s: 1.2}
      heavy_tails: {dof: 4.5}
      variance_regimes: {scales: [1.0, 2.4],
                         transition: [[0.98, 0.02], [0.05, 0.95]]}
      street_frame: {sigma_along: 0.6, sigma_across: 1.4}
      periodic: {period_steps: 8, scales: [...], offsets: [[n, e], ...]}
      outliers: {rate: 0.01, mean_steps: 2.0, sigma_m: 12.0}

The process, per model step ``k``::

    u(k) = delta + sum_i phi_i u(k - i) + s[r(k)] * w(k)
    reported position = truth(t - lag_s) + u(k) + o(k)

* ``w(k)`` has covariance ``[[sn^2, c sn se], [c sn se, se^2]]`` with
  ``sn, se`` the axes' ``sigma_w`` and ``c`` the ``innovation_corr``; it is
  Gaussian, or bivariate Student-t with ``dof`` degrees of freedom scaled to
  the same covariance (one shared mixing variable per step, so a multipath
  jump moves both axes together).
* ``r(k)`` is a Markov chain over the regimes with the given row-stochastic
  ``transition`` matrix; regime ``j`` multiplies the innovations by
  ``scales[j]``. Without the section there is one regime of scale 1.
* ``street_frame`` replaces the innovation covariance of the axes by one in
  the axes along and across the direction of travel: ``w(k) = R(theta)
  [sigma_along z1, sigma_across z2]``, with ``theta`` the direction (from
  north, clockwise) of the truth's last second of travel (moving at least
  ``MOVING_M`` metres; slower, the last direction holds; north before the
  first). So the error ellipse turns with the walker; the AR coefficients
  stay per north/east axis. Not with ``cross_axis_coupling`` (both set the
  innovation covariance). Its stationary covariance, the one published in
  ``stationary`` mode, is the average over directions: the AR process with
  innovation variance ``(sigma_along^2 + sigma_across^2) / 2`` per axis.
* ``lag_s``: the receiver reports where the device was ``lag_s`` seconds
  ago; the error relative to the truth at the stamp is ``u(k)`` plus
  ``truth(t - lag_s) - truth(t)`` (zero when standing, about ``-lag_s *
  velocity`` when walking).
* ``periodic`` (:mod:`periodic`): at the agent's phase ``j`` of a cycle of
  ``period_steps`` the innovation is ``offsets[j] + scales[j] * s[r(k)] *
  w(k)``; the state carries the phase.
* ``o(k)`` (:mod:`outliers`): zero, or a jump's offset held for a few steps;
  outside the AR recursion, so it does not persist once the jump ends.

Covariance: the AR part is linear, so its stationary covariance is the
Lyapunov solution for the *average* innovation covariance, ``E[s^2]`` times
the covariance of ``w``, with ``E[s^2] = sum_j pi_j scales[j]^2`` over the
chain's stationary distribution ``pi``, plus the cycle's and the jumps' own
(exact) parts. That unconditional covariance is what the node publishes
(it does not depend on the hidden regime; the Student-t scaling keeps the
covariance of ``w`` as stated). The lag term is a motion-dependent offset,
not part of it.
"""

import math
from typing import Optional

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.model.effect_kind import Term
from gps_error_ros.model.effect_schema import (  # noqa: F401 (the schema, re-exported)

    EFFECT_NAMES, Effects, effects_from_dict, EffectsError, MAX_DOF, MAX_LAG_S, MOVING_M,
    stationary_distribution)
from gps_error_ros.model.protocol import Inputs, opaque, OpaqueProcess, Process
from gps_error_ros.model.state import (EffectsState, FloatArray, IntArray, Keys,
                                       Numbers, zeros_effects_state)


__all__ = ['EFFECT_NAMES', 'Effects', 'EffectsError', 'ExtendedModel', 'MAX_DOF', 'MAX_LAG_S',
           'MOVING_M', 'build_model', 'effects_from_dict', 'stationary_distribution']


def _overriding(terms: list[Term], hook: str) -> list[Term]:
    """Return the terms whose class overrides ``hook`` of :class:`Term`, in order."""
    return [t for t in terms if getattr(type(t), hook) is not getattr(Term, hook)]


class ExtendedModel(Process[EffectsState]):
    """
    The AR(p) process with effects; same interface as :class:`ARErrorModel`.

    The state of ``n`` agents is an :class:`~.state.EffectsState`: the AR
    deviations (the cycle's mean included), the regime, the direction of
    travel, the phase in the cycle and the jump under way. Draws come from the agents'
    counter-based streams, one position per model step, so an agent's errors
    do not depend on how many agents are simulated together or when its
    state was created. Each effect's part is its kind's :class:`~.effect_kind.Term`
    (:mod:`~.effect_kinds`), called at its hooks in the kinds' ``stage`` order.
    """

    def __init__(self, north: AxisParams, east: AxisParams, effects: Effects) -> None:
        self.effects = effects
        self.street = effects.street
        corr = 0.0
        for kind, params in effects:
            north, east, corr = kind.ar(params, north, east, corr)
        self.unit = ARErrorModel(north, east, corr)
        self.axes = self.unit.axes
        self.order = self.unit.order
        self.phi = self.unit.phi
        self.mean = self.unit.mean
        self.lag_s = effects.lag_s
        staged = sorted(((kind.stage, kind.order, kind.term(params, self.phi, self.order))
                         for kind, params in effects), key=lambda s: (s[0], s[1]))
        self.terms = [t for _, _, t in staged if t is not None]
        self._needs_heading = any(kind.needs_heading for kind, _ in effects)
        setting = _overriding(self.terms, 'innovations')
        self._innovator = setting[0] if setting else None
        self._shapers = _overriding(self.terms, 'shape')
        self._outputs = _overriding(self.terms, 'output')
        self._currents = _overriding(self.terms, 'current')
        self._initials = _overriding(self.terms, 'initial')
        self._resumes = [t for t in self.terms if t in self._initials
                         or type(t).resume is not Term.resume]
        self._factors = _overriding(self.terms, 'step_factor')
        self._added = _overriding(self.terms, 'added_cov')
        self._means = _overriding(self.terms, 'mean_term')
        self._acvs = _overriding(self.terms, 'autocovariance')
        self.variance_factor = 1.0
        for t in self.terms:
            self.variance_factor *= t.variance_factor
        self._init_scale = math.sqrt(self.variance_factor)

    @property
    def stationary_cov(self) -> FloatArray:
        """Return the unconditional 2x2 (north, east) error covariance (phase-averaged)."""
        return self.autocovariance(0)[0]

    @property
    def stationary_sd(self) -> FloatArray:
        """Return the unconditional standard deviation per axis."""
        return np.sqrt(np.diag(self.stationary_cov))

    def autocovariance(self, max_lag: int) -> FloatArray:
        """Return the exact unconditional autocovariance, (max_lag + 1, 2, 2)."""
        out = self.unit.autocovariance(max_lag) * self.variance_factor
        for t in self._acvs:
            out = out + t.autocovariance(max_lag)
        return out

    def autocorrelation(self, max_lag: int) -> FloatArray:
        """Return the exact autocorrelation per axis (max_lag + 1, 2)."""
        acv = self.autocovariance(max_lag)
        diag = np.stack([acv[:, 0, 0], acv[:, 1, 1]], axis=1)
        return diag / diag[0]

    @property
    def needs_heading(self) -> bool:
        """Return True when an effect's step needs the direction of travel."""
        return self._needs_heading

    def empty_state(self, n: int) -> EffectsState:
        """Return the state of ``n`` agents, all zeros."""
        return zeros_effects_state(n, self.order)

    def face(self, state: EffectsState, heading: Numbers) -> None:
        """Set the direction of travel of every agent (radians; NaN: the last one holds)."""
        heading = np.broadcast_to(np.asarray(heading, dtype=float), (len(state),))
        moving = np.isfinite(heading)
        state.heading[moving] = heading[moving]

    def _face(self, state: EffectsState, inputs: Inputs) -> None:
        """Turn the agents to ``inputs.heading`` where an effect needs it and it is given."""
        if self._needs_heading and inputs is not None and inputs.heading is not None:
            self.face(state, inputs.heading)

    def initial_state(self, keys: Keys, index: int, inputs: Inputs = None) -> EffectsState:
        """
        Draw the state at model step ``index``.

        The AR part Gaussian with the unconditional stationary covariance
        (under heavy tails or regimes the exact law is not Gaussian; the
        difference fades within the process's correlation time), then each
        effect's own (the regime from the chain's stationary law, the
        cycle's phase, a jump under way). ``inputs``: the direction of
        travel at the start (north where unknown).
        """
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        state = self.empty_state(keys.size)
        self._face(state, inputs)
        state.deviations[:] = self.unit.initial_state(keys, index).deviations * \
            self._init_scale
        for t in self._initials:
            t.initial(state, keys, index)
        return state

    def advance(self, state: EffectsState, keys: Keys, index: int,
                inputs: Inputs = None) -> FloatArray:
        """
        Advance ``state`` in place to model step ``index``; return errors.

        ``inputs.heading`` (n,) radians: the direction of travel at this step
        (NaN: standing, the last direction holds).
        """
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        p = self.order
        z = streams.normal_pairs(keys, streams.DOMAIN_STEP, index)
        self._face(state, inputs)
        if self._innovator is not None:
            w = self._innovator.innovations(state, z)
        else:
            w = self.unit._innovations(z)
        for t in self._shapers:
            w = t.shape(state, keys, index, w)
        dev = state.deviations
        for i in range(p):
            w += self.phi[:, i] * dev[:, :, i]
        dev[:, :, 1:p] = dev[:, :, 0:p - 1]
        dev[:, :, 0] = w
        out: FloatArray = w + self.mean
        for t in self._outputs:
            out = t.output(state, keys, index, out)
        return out

    def street_cov(self, state: EffectsState) -> FloatArray:
        """Return each agent's innovation covariance (n, 2, 2) in its direction of travel."""
        if self._innovator is None:
            raise ValueError('no effect of this model turns the innovations')
        return self._innovator.innovation_cov(state)

    def errors(self, state: EffectsState) -> FloatArray:
        """Return the current errors, mean (and any jump) included, shape (n, 2)."""
        out: FloatArray = state.deviations[:, :, 0] + self.mean
        for t in self._currents:
            out = t.current(state, out)
        return out

    def _innovation_cov(self, state: EffectsState) -> FloatArray:
        """Return the innovation covariance, per agent (n, 2, 2) or shared (1, 2, 2)."""
        if self._innovator is not None:
            return self._innovator.innovation_cov(state)
        return self.unit.innovation_cov[None]

    def predictive_cov(self, state: EffectsState, first: bool = False) -> FloatArray:
        """
        Return each agent's covariance (n, 2, 2) of the next error given ``state``.

        The innovation covariance (turned to the last direction of travel
        under street_frame) times the factor the effects give the next step
        (the expected squared regime scale given the current regime, the
        next phase's squared scale; heavy tails keep the unit variance),
        plus what an effect adds outside the AR part (the next jump offset's
        covariance given the jump state). ``first``: a run's first error is
        drawn from the stationary law, so its covariance is
        :attr:`stationary_cov` (phases, regimes and jumps averaged).
        """
        n = len(state)
        if first:
            return np.repeat(self.stationary_cov[None], n, axis=0)
        factor = np.ones(n)
        for t in self._factors:
            factor = factor * t.step_factor(state)
        cov = self._innovation_cov(state) * factor[:, None, None]
        for t in self._added:
            cov = cov + t.added_cov(state, False)
        return cov

    def mean_step_cov(self) -> FloatArray:
        """
        Return the one-step covariance (2, 2) averaged over the stationary law.

        The innovation covariance times the effects' stationary mean square
        scale, plus a jump's stationary share (the reference of a stated
        radius that follows the predictive scale). With street_frame the
        innovation covariance facing north.
        """
        one = self.empty_state(1)
        cov = self._innovation_cov(one)[0] * self.variance_factor
        for t in self._added:
            cov = cov + t.added_cov(one, True)[0]
        return cov

    def predictive_mean(self, state: EffectsState, first: bool = False) -> FloatArray:
        """
        Return each agent's expected next error (n, 2) given ``state``, mean included.

        The AR part of the deviations held, and what the effects add (the
        next phase's cycle offset; what is left of a jump under way, kept
        with probability ``1 - q``, a new jump's offset having mean zero).
        ``first``: the stationary mean. The motion lag is not in it (it
        needs the truth).
        """
        out = np.repeat(self.mean[None], len(state), axis=0)
        if first:
            return out
        for i in range(self.order):
            out += self.phi[:, i] * state.deviations[:, :, i]
        for t in self._means:
            out += t.mean_term(state)
        return out

    def prepare(self, state: EffectsState, keys: Keys, index: int,
                inputs: Inputs = None) -> None:
        """Turn the agents to step ``index``'s direction of travel (effects that need it)."""
        self._face(state, inputs)

    def carried(self, state: EffectsState) -> FloatArray:
        """Return the AR part's last ``p`` errors (n, 2, p), mean included, no jump (zones)."""
        return state.deviations + self.mean[None, :, None]

    def resumed(self, carried: FloatArray, keys: Keys, index: int,
                inputs: Inputs = None) -> EffectsState:
        """
        Return the state of agents entering this process at ``index`` with errors ``carried``.

        The AR recursion continues from ``carried`` (n, 2, P >= p, newest
        first); what the errors do not carry is this process's own, drawn as
        a new run's is at ``index``: the regime and a jump under way from
        their stationary laws, the cycle's phase from the agent's offset
        (the state before step ``index``); the direction of travel is
        ``inputs.heading``.
        """
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        state = self.empty_state(keys.size)
        state.deviations[:] = carried[:, :, :self.order] - self.mean[None, :, None]
        if inputs is not None and inputs.heading is not None:
            self.face(state, inputs.heading)
        for t in self._resumes:
            t.resume(state, keys, index)
        return state

    def regimes(self, state: EffectsState) -> IntArray:
        """Return the current regime index of each agent."""
        return state.regime.copy()

    def state_after(self, keys: Keys, start: int, step: int,
                    inputs: Inputs = None) -> EffectsState:
        """
        Return the state at model step ``step`` of a run started at ``start``.

        ``inputs`` (street_frame: the direction of travel) hold at every step.
        """
        state = self.initial_state(keys, start, inputs)
        for k in range(start + 1, step + 1):
            self.advance(state, keys, k, inputs)
        return state

    def simulate(self, keys: Keys, n_steps: int, start: int = 0,
                 out: Optional[FloatArray] = None) -> FloatArray:
        """
        Simulate errors at model steps ``start .. start + n_steps - 1``.

        As :meth:`ARErrorModel.simulate`, stepping through time vectorised
        over agents. The lag is not applied (it needs the truth): add
        :func:`~.motion_lag.lag_offsets` of the trajectory.
        """
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        if out is None:
            out = np.empty((n_steps, keys.size, 2))
        if n_steps == 0:
            return out
        state = self.initial_state(keys, start)
        out[0] = self.errors(state)
        for k in range(1, n_steps):
            out[k] = self.advance(state, keys, start + k)
        return out


def build_model(north: AxisParams, east: AxisParams,
                effects: Optional[Effects] = None) -> OpaqueProcess:
    """Return the plain AR model, or an :class:`ExtendedModel` with effects."""
    if effects is None or not effects.names:
        return opaque(ARErrorModel(north, east))
    return opaque(ExtendedModel(north, east, effects))

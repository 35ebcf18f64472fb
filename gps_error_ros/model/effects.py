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
from gps_error_ros.model import outliers as jumps
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.model.effect_schema import (  # noqa: F401 (the schema, re-exported)

    EFFECT_NAMES, Effects, effects_from_dict, EffectsError, MAX_DOF, MAX_LAG_S, MOVING_M,
    stationary_distribution)
from gps_error_ros.model.periodic import agent_phases, mean_autocovariance, periodic_mean
from gps_error_ros.model.protocol import Inputs, Process
from gps_error_ros.model.state import (EffectsState, FloatArray, IntArray, Keys,
                                       Numbers, zeros_effects_state)


__all__ = ['EFFECT_NAMES', 'Effects', 'EffectsError', 'ExtendedModel', 'MAX_DOF', 'MAX_LAG_S',
           'MOVING_M', 'build_model', 'effects_from_dict', 'stationary_distribution']


class ExtendedModel(Process[EffectsState]):
    """
    The AR(p) process with effects; same interface as :class:`ARErrorModel`.

    The state of ``n`` agents is an :class:`~.state.EffectsState`: the AR
    deviations (the cycle's mean included), the regime, the direction of
    travel, the phase in the cycle and the jump under way. Draws come from the agents'
    counter-based streams, one position per model step, so an agent's errors
    do not depend on how many agents are simulated together or when its
    state was created.
    """

    def __init__(self, north: AxisParams, east: AxisParams, effects: Effects) -> None:
        self.effects = effects
        self.street = effects.street
        if self.street is not None:
            # the AR part with the innovation variance averaged over directions
            sw = math.sqrt(0.5 * (self.street[0] ** 2 + self.street[1] ** 2))
            north = AxisParams(north.delta, north.phi, sw)
            east = AxisParams(east.delta, east.phi, sw)
        self.unit = ARErrorModel(north, east, effects.innovation_corr)
        self.axes = self.unit.axes
        self.order = self.unit.order
        self.phi = self.unit.phi
        self.mean = self.unit.mean
        self.lag_s = effects.lag_s
        self.scales = np.asarray(effects.scales, dtype=float)
        self.cum_transition = np.cumsum(np.asarray(effects.transition), axis=1)
        self.cum_transition[:, -1] = 1.0
        self.pi = effects.regime_probabilities
        self.cum_pi = np.cumsum(self.pi)
        self.cum_pi[-1] = 1.0
        self.dof = effects.dof
        self._init_scale = math.sqrt(effects.variance_factor)
        self.periodic = effects.periodic
        if self.periodic is not None:
            self.cycle_scales = np.asarray(self.periodic.scales, dtype=float)
            self.cycle_offsets = np.asarray(self.periodic.offsets, dtype=float)
            self.cycle_mean = periodic_mean(self.phi, self.cycle_offsets)
        self.outliers = effects.outliers

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
        out = self.unit.autocovariance(max_lag) * self.effects.variance_factor
        if self.periodic is not None:
            out = out + mean_autocovariance(self.cycle_mean, max_lag)
        if self.outliers is not None:
            out = out + self.outliers.autocovariance(max_lag)[:, None, None] * np.eye(2)
        return out

    def autocorrelation(self, max_lag: int) -> FloatArray:
        """Return the exact autocorrelation per axis (max_lag + 1, 2)."""
        acv = self.autocovariance(max_lag)
        diag = np.stack([acv[:, 0, 0], acv[:, 1, 1]], axis=1)
        return diag / diag[0]

    @property
    def needs_heading(self) -> bool:
        """Return True when the innovations turn with the direction of travel."""
        return self.street is not None

    def empty_state(self, n: int) -> EffectsState:
        """Return the state of ``n`` agents, all zeros."""
        return zeros_effects_state(n, self.order)

    def face(self, state: EffectsState, heading: Numbers) -> None:
        """Set the direction of travel of every agent (radians; NaN: the last one holds)."""
        heading = np.broadcast_to(np.asarray(heading, dtype=float), (len(state),))
        moving = np.isfinite(heading)
        state.heading[moving] = heading[moving]

    def initial_state(self, keys: Keys, index: int, inputs: Inputs = None) -> EffectsState:
        """
        Draw the state at model step ``index``.

        The regime from the chain's stationary distribution; the AR part
        Gaussian with the unconditional stationary covariance (under heavy
        tails or regimes the exact law is not Gaussian; the difference fades
        within the process's correlation time). ``inputs``: the direction
        of travel at the start (street_frame; north where unknown).
        """
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        state = self.empty_state(keys.size)
        if self.street is not None and inputs is not None and inputs.heading is not None:
            self.face(state, inputs.heading)
        state.deviations[:] = self.unit.initial_state(keys, index).deviations * \
            self._init_scale
        if self.scales.size > 1:
            u = streams.uniform_pairs(keys, streams.DOMAIN_INIT_REGIME,
                                      index)[:, 0]
            state.regime[:] = np.searchsorted(self.cum_pi, u, side='right')
        if self.periodic is not None:
            p, period = self.order, self.periodic.period
            offset = agent_phases(keys, period)
            phase = (offset + index) % period
            state.cycle_offset[:], state.phase[:] = offset, phase
            for i in range(p):          # the lags sit at their phases' cycle mean
                state.deviations[:, :, i] += self.cycle_mean[(phase - i) % period]
        if self.outliers is not None:
            state.in_jump[:], state.jump[:] = jumps.initial_offsets(self.outliers, keys, index)
        return state

    def advance(self, state: EffectsState, keys: Keys, index: int,
                inputs: Inputs = None) -> FloatArray:
        """
        Advance ``state`` in place to model step ``index``; return errors.

        ``inputs.heading`` (n,) radians: the direction of travel at this step
        (street_frame; NaN: standing, the last direction holds).
        """
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        p = self.order
        z = streams.normal_pairs(keys, streams.DOMAIN_STEP, index)
        if self.street is not None:
            w = self._street_innovations(state, z, None if inputs is None else inputs.heading)
        else:
            w = self.unit._innovations(z)
        if self.scales.size > 1:
            u = streams.uniform_pairs(keys, streams.DOMAIN_REGIME, index)[:, 0]
            nxt = (u[:, None] >= self.cum_transition[state.regime]).sum(axis=1)
            nxt = np.minimum(nxt, self.scales.size - 1)
            state.regime[:] = nxt
            w *= self.scales[nxt][:, None]
        if math.isfinite(self.dof):
            u = streams.uniform_pairs(keys, streams.DOMAIN_TAIL, index)[:, 0]
            half = 0.5 * self.dof
            from scipy import special       # here: a node without tails need not import scipy
            mix = special.gammaincinv(half, u) / half        # chi2(dof) / dof
            w *= np.sqrt((self.dof - 2.0) / self.dof / mix)[:, None]
        if self.periodic is not None:
            phase = (state.cycle_offset + index) % self.periodic.period
            state.phase[:] = phase
            w = w * self.cycle_scales[phase][:, None] + self.cycle_offsets[phase]
        dev = state.deviations
        for i in range(p):
            w += self.phi[:, i] * dev[:, :, i]
        dev[:, :, 1:p] = dev[:, :, 0:p - 1]
        dev[:, :, 0] = w
        if self.outliers is not None:
            jumps.advance_offsets(self.outliers, state.in_jump, state.jump, keys, index)
            return w + self.mean + state.jump
        return w + self.mean

    def _street_innovations(self, state: EffectsState, z: FloatArray,
                            heading: Optional[FloatArray]) -> FloatArray:
        """Return the innovations along/across the direction of travel, as north/east."""
        if heading is not None:
            self.face(state, heading)
        theta = state.heading
        c, s = np.cos(theta), np.sin(theta)
        along_sd, across_sd = self._street_sd()
        along, across = along_sd * z[:, 0], across_sd * z[:, 1]
        return np.stack([along * c - across * s, along * s + across * c], axis=1)

    def _street_sd(self) -> tuple[float, float]:
        """Return the innovation SDs (along, across) of a street frame."""
        if self.street is None:
            raise ValueError('no street_frame in this model\'s effects')
        return self.street

    def street_cov(self, state: EffectsState) -> FloatArray:
        """Return each agent's innovation covariance (n, 2, 2) in its direction of travel."""
        theta = state.heading
        c, s = np.cos(theta), np.sin(theta)
        along_sd, across_sd = self._street_sd()
        a2, x2 = along_sd ** 2, across_sd ** 2
        out = np.empty((theta.size, 2, 2))
        out[:, 0, 0] = a2 * c * c + x2 * s * s
        out[:, 1, 1] = a2 * s * s + x2 * c * c
        out[:, 0, 1] = out[:, 1, 0] = (a2 - x2) * c * s
        return out

    def errors(self, state: EffectsState) -> FloatArray:
        """Return the current errors, mean (and any jump) included, shape (n, 2)."""
        if self.outliers is not None:
            return state.deviations[:, :, 0] + self.mean + state.jump
        return state.deviations[:, :, 0] + self.mean

    def predictive_cov(self, state: EffectsState, first: bool = False) -> FloatArray:
        """
        Return each agent's covariance (n, 2, 2) of the next error given ``state``.

        The innovation covariance times the expected squared regime scale of
        the next step given the current regime and the next phase's squared
        scale; heavy tails keep the unit variance. With street_frame the
        covariance is turned to the last direction of travel. With outliers
        the next offset's covariance given the jump state is added
        (:func:`~.outliers.offset_cov`). ``first``: a run's first error is
        drawn from the stationary law, so its covariance is
        :attr:`stationary_cov` (phases, regimes and jumps averaged).
        """
        n = len(state)
        if first:
            return np.repeat(self.stationary_cov[None], n, axis=0)
        factor = np.ones(n)
        if self.scales.size > 1:
            s2 = self.scales ** 2
            factor = np.asarray(self.effects.transition)[state.regime] @ s2
        if self.periodic is not None:
            nxt = (state.phase + 1) % self.periodic.period
            factor = factor * self.cycle_scales[nxt] ** 2
        base = self.street_cov(state) if self.street is not None else \
            self.unit.innovation_cov[None]
        cov = base * factor[:, None, None]
        if self.outliers is not None:
            cov = cov + jumps.offset_cov(self.outliers, state.in_jump, state.jump)
        return cov

    def mean_step_cov(self) -> FloatArray:
        """
        Return the one-step covariance (2, 2) averaged over the stationary law.

        The innovation covariance times the regimes' stationary mean square
        scale and the cycle's average, plus a jump's stationary share (the
        reference of a stated radius that follows the predictive scale).
        With street_frame the innovation covariance facing north.
        """
        factor = 1.0
        if self.scales.size > 1:
            factor = float(self.pi @ self.scales ** 2)
        if self.periodic is not None:
            factor *= self.periodic.variance_factor
        base = self.street_cov(self.empty_state(1))[0] if self.street is not None else \
            self.unit.innovation_cov
        cov = base * factor
        if self.outliers is not None:
            cov = cov + jumps.offset_cov(self.outliers, np.zeros(1), np.zeros((1, 2)),
                                         first=True)[0]
        return cov

    def predictive_mean(self, state: EffectsState, first: bool = False) -> FloatArray:
        """
        Return each agent's expected next error (n, 2) given ``state``, mean included.

        The AR part of the deviations held, the next phase's cycle offset
        (periodic) and what is left of a jump under way (outliers, kept with
        probability ``1 - q``; a new jump's offset has mean zero). ``first``:
        the stationary mean. The motion lag is not in it (it needs the truth).
        """
        out = np.repeat(self.mean[None], len(state), axis=0)
        if first:
            return out
        for i in range(self.order):
            out += self.phi[:, i] * state.deviations[:, :, i]
        if self.periodic is not None:
            nxt = (state.phase + 1) % self.periodic.period
            out += self.cycle_offsets[nxt]
        if self.outliers is not None:
            out += (1.0 - self.outliers.end_probability) * \
                (state.in_jump > 0.5)[:, None] * state.jump
        return out

    def prepare(self, state: EffectsState, keys: Keys, index: int,
                inputs: Inputs = None) -> None:
        """Turn the agents to step ``index``'s direction of travel (street_frame)."""
        if self.street is not None and inputs is not None and inputs.heading is not None:
            self.face(state, inputs.heading)

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
        if self.scales.size > 1:
            u = streams.uniform_pairs(keys, streams.DOMAIN_INIT_REGIME, index)[:, 0]
            state.regime[:] = np.searchsorted(self.cum_pi, u, side='right')
        if self.periodic is not None:
            offset = agent_phases(keys, self.periodic.period)
            state.cycle_offset[:] = offset
            state.phase[:] = (offset + index - 1) % self.periodic.period
        if self.outliers is not None:
            state.in_jump[:], state.jump[:] = jumps.initial_offsets(self.outliers, keys, index)
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
                effects: Optional[Effects] = None) -> ARErrorModel | ExtendedModel:
    """Return the plain AR model, or an :class:`ExtendedModel` with effects."""
    if effects is None or not effects.names:
        return ARErrorModel(north, east)
    return ExtendedModel(north, east, effects)

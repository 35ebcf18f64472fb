"""
The population class of the folds: a population profile fitted on a training part, scored.

``population_ar`` is the profile ``calibrate --population`` writes (the
Gaussian AR within blocks of
:data:`~gps_error_ros.fit.population_fit.BLOCK_S`); ``population`` the same
section on the extended model fitted on the training errors about their
blocks' means (:func:`within_part`). Each is scored by the held-out
predictive of the model it simulates: an exact Kalman filter over the AR and
the bias for the first, and for the second the within model's densities
averaged over the run's bias and the agent's scale
(:meth:`PopulationClass._mixture_logpdf`; why: decision record 0012 in
``docs/decisions``).
"""

from collections.abc import Sequence
from dataclasses import replace
from types import SimpleNamespace
from typing import Any, TYPE_CHECKING

import numpy as np

from gps_error_ros.fit.holdout import motion_offsets
from gps_error_ros.fit.holdout import Part, Split, TruthTrack
from gps_error_ros.fit.population_fit import block_means, block_pieces, BLOCK_S, fit_population
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.model.effects import build_model
from gps_error_ros.model.population import Population, WithPopulation
from gps_error_ros.model.protocol import opaque, OpaqueModel
from gps_error_ros.model.state import FloatArray

if TYPE_CHECKING:
    from gps_error_ros.diagnose.models import FittedModel


class PopulationClass:
    """
    The population profile fitted on a training part, as a class to judge.

    ``within``: a :class:`~gps_error_ros.diagnose.models.FittedModel` fitted on the training
    errors about their blocks' means (:func:`within_part`), whose effects
    the class keeps; without it the process within is the Gaussian AR of
    :func:`~gps_error_ros.fit.population_fit.fit_population`.
    """

    def __init__(self, train: Part, within: 'FittedModel | None' = None,
                 truth: TruthTrack | None = None,
                 weights: Sequence[float] | None = None) -> None:
        self.lag = (0.0, 1.0) if within is None else (within.mean.lag_s, within.mean.gain)
        self.truth = truth
        # a bias on two time scales where the scorer can follow it (the Kalman filter's)
        fit = fit_population(self._without_lag(train), train.t, weights=weights,
                             two_scales=within is None)
        self.fit, self.within = fit, within
        self.ar = ARErrorModel(*fit.axis_params())
        inner: OpaqueModel = opaque(self.ar)
        if within is not None:
            axes = [AxisParams((1.0 - sum(p.phi)) * float(m), p.phi, p.sigma_w)
                    for p, m in zip(within.axis_params(), fit.mean)]
            inner = build_model(axes[0], axes[1], within.effects_obj())
        self.axes = axes if within is not None else fit.axis_params()
        pop = fit.population
        self.model = inner if pop is None else opaque(WithPopulation(inner, pop))
        self.mean: Any = within.mean if within is not None else \
            SimpleNamespace(lag_s=0.0, gain=1.0)

    def _without_lag(self, part: Part) -> list[FloatArray]:
        """Return ``part``'s error segments less the motion lag's offsets."""
        offsets = motion_offsets(part, self.truth, *self.lag)
        return [e - o for e, o in zip(part.err, offsets)]

    def simulator(self) -> OpaqueModel:
        """Return the model to simulate with."""
        return self.model

    def logpdf(self, part: Part, m0: int) -> FloatArray:
        """
        Return the held-out one-step log densities of the scored samples.

        A Kalman filter per axis over the Gaussian AR state and the bias (the
        scale taken at its mean square, 1) predicts each sample given every
        earlier held-out sample (gaps predicted through; the filter sees the
        errors less the motion lag's offsets). With a ``within`` model the
        bias is integrated over instead (:meth:`_mixture_logpdf`). The first
        ``m0`` samples of each segment are conditioned on, not scored.
        """
        pop = self.fit.population
        if self.within is not None:
            return self._mixture_logpdf(part, m0)
        out = np.zeros(part.n)
        free = Part(self._without_lag(part), part.truth, part.t)
        for a in range(2):
            ax = self.ar.axes[a]
            sd = 0.0 if pop is None else pop.bias_sd_m[a]
            rate = 1.0 if pop is None else pop.persistence()
            held = 0.0 if pop is None or pop.run_bias_sd_m is None else pop.run_bias_sd_m[a]
            out += _kalman_ll(free, a, np.asarray(ax.phi, dtype=float), ax.sigma_w,
                              float(self.ar.mean[a]), sd, rate, held)
        starts = np.cumsum([0] + [len(e) for e in part.err[:-1]])
        keep = np.concatenate([s + np.arange(m0, len(e))
                               for s, e in zip(starts, part.err)])
        return out[keep]

    def _mixture_logpdf(self, part: Part, m0: int) -> FloatArray:
        """
        Return the held-out one-step log densities under the ``within`` model and the population.

        A run's bias and its agent's scale are unknown, so the prediction
        averages the within model's over their laws: the bias on a grid of
        :data:`BIAS_NODES` values per axis (out to :data:`BIAS_REACH` SDs,
        weighted by the law's density: normal, or Student-t with a factor
        shared by the axes), the scale ``f`` on a grid of :data:`SCALE_NODES`
        values of its log-normal law. The weights are updated by
        each sample's likelihood (the forward pass of a hidden Markov chain
        over the grid). The scale holds for the run; a bias that wanders with
        factor ``a`` per second keeps its node with probability ``a ** dt``
        and is drawn afresh from its law otherwise. Each node's densities are
        the within model's of ``(error - grand mean - bias) / f`` (less
        ``2 log f``), so every lag of a prediction sees one bias and scale.
        """
        pop, within, truth = self.fit.population, self.within, self.truth
        if within is None or truth is None:
            raise AssertionError('the mixture scores a class with a model within, and truth')
        if pop is None:
            return within.score(Part([e - self.fit.mean for e in part.err],
                                     part.truth, part.t), truth, m0)[0]
        nodes, log_bias = bias_grid(pop)
        scales, log_scale = scale_nodes(pop.scale_sd_log)
        t = np.concatenate([tt[m0:] for tt in part.t])
        per_scale = []
        for f in scales:            # one scale at a time: (nodes, scored) in memory
            lls = np.array([within.score(Part([(e - self.fit.mean - b) / f
                                               for e in part.err], part.truth, part.t),
                                         truth, m0)[0] for b in nodes])
            if t.size != lls.shape[1]:
                raise AssertionError(f'scored {lls.shape[1]} samples, expected {t.size}')
            per_scale.append(bias_forward(lls - 2.0 * np.log(f), log_bias, t,
                                          pop.persistence()))
        return over_scales(np.array(per_scale), log_scale)


def bias_forward(lls: FloatArray, log_bias: FloatArray, t: FloatArray,
                 rate: float) -> FloatArray:
    """
    Return each sample's predictive log density given one scale, averaged over the bias nodes.

    ``lls`` (biases, n): each bias node's own one-step log densities;
    ``log_bias``: the nodes' log prior weights; ``t`` (n,): the samples'
    times, s; ``rate``: the bias's factor per second (1: fixed for the run).
    Between samples ``dt`` apart the bias keeps its node with probability
    ``rate ** dt`` and is drawn afresh from its prior otherwise.
    """
    out = np.empty(t.size)
    state = np.array(log_bias, dtype=float)
    for i in range(t.size):
        if i and rate < 1.0:
            # within (0, 1): a wander slower than a float can tell is kept, never -inf
            keep = min(max(rate ** max(1.0, float(t[i] - t[i - 1])), 1e-300), 1.0 - 1e-16)
            state = np.logaddexp(np.log(keep) + state, np.log1p(-keep) + log_bias)
        joint = state + lls[:, i]
        out[i] = np.logaddexp.reduce(joint)
        state = joint - out[i]
    return out


def over_scales(lps: FloatArray, log_scale: FloatArray) -> FloatArray:
    """
    Return each sample's predictive log density averaged over the agent's scale.

    ``lps`` (scales, n): each scale node's predictive log densities
    (:func:`bias_forward`); the scale holds for the run, so node ``j``
    weighs its prior times the likelihood of the samples before.
    """
    before = np.cumsum(lps, axis=1) - lps                  # log likelihood of the earlier samples
    prior = np.asarray(log_scale, dtype=float)[:, None] + before
    return np.logaddexp.reduce(prior + lps, axis=0) - np.logaddexp.reduce(prior, axis=0)


def mixture_forward(lls: FloatArray, log_scale: FloatArray, log_bias: FloatArray,
                    t: FloatArray, rate: float) -> FloatArray:
    """
    Return each sample's predictive log density, averaged over scale and bias nodes.

    ``lls`` (scales, biases, n): each node's own one-step log densities;
    ``log_scale``, ``log_bias``: the nodes' log prior weights; ``t`` (n,):
    the samples' times, s; ``rate``: the bias's factor per second (1: fixed
    for the run). The scale holds for the run (:func:`over_scales`); the
    bias as :func:`bias_forward` has it. With ``rate`` 1 the densities sum
    to the log of the nodes' prior-weighted joint likelihoods.
    """
    return over_scales(np.array([bias_forward(ll, log_bias, t, rate) for ll in lls]),
                       log_scale)


#: Bias values per axis on the grid the within model's predictions are averaged over.
BIAS_NODES = 21
#: How far the grid reaches, in SDs of the bias law.
BIAS_REACH = 4.0
#: Nodes of an agent's log scale, evenly spaced over ``SCALE_REACH`` SDs either side.
SCALE_NODES = 31
#: How far the scale's nodes reach, in SDs of its log.
SCALE_REACH = 4.0


def scale_nodes(scale_sd_log: float) -> tuple[FloatArray, FloatArray]:
    """
    Return (scales ``f``, log weights) of an agent's scale law on a grid.

    ``f = exp(s z - s^2)``, ``z`` standard normal (the population model's
    law, whose ``f^2`` has mean 1), ``z`` at :data:`SCALE_NODES` even steps
    weighted by its density; one node ``f = 1`` when ``s`` is 0. A grid, not
    Gauss-Hermite nodes: a long held-out run pins its scale far more finely
    than a few nodes resolve, and the score would pay for the gap between
    them (0.02-0.06 nats per sample on the Pixel 4 with 5 nodes).
    """
    if scale_sd_log == 0.0:
        return np.ones(1), np.zeros(1)
    z = np.linspace(-SCALE_REACH, SCALE_REACH, SCALE_NODES)
    log_w = -0.5 * z * z
    return np.exp(scale_sd_log * z - scale_sd_log ** 2), log_w - np.logaddexp.reduce(log_w)


def bias_grid(pop: Population) -> tuple[FloatArray, FloatArray]:
    """
    Return (nodes (k, 2), log weights (k,)) of a population's bias law on a grid.

    ``BIAS_NODES`` values per axis from ``-BIAS_REACH`` to ``BIAS_REACH``
    SDs; the weights are the law's density at the nodes, normalised (the
    Student-t's scale chosen so that its SD is ``bias_sd_m``, one factor
    shared by the axes as the model draws it). An axis whose SD is 0 has
    the one node 0.
    """
    axes = [np.linspace(-BIAS_REACH, BIAS_REACH, BIAS_NODES) if sd > 0 else np.zeros(1)
            for sd in pop.bias_sd_m]
    z = np.array([(a, b) for a in axes[0] for b in axes[1]])           # in SDs
    q = np.sum(z * z, axis=1)
    if pop.bias_dof is None:
        log_w = -0.5 * q
    else:
        nu = float(pop.bias_dof)
        log_w = -0.5 * (nu + 2.0) * np.log1p(q / (nu - 2.0))   # unit SD, 2-D t
    log_w = log_w - np.logaddexp.reduce(log_w)
    return z * np.asarray(pop.bias_sd_m, dtype=float), log_w


def _within_split(split: Split) -> Split:
    """Return ``split`` with its training part about its blocks' means (:func:`within_part`)."""
    return replace(split, train=within_part(split.train), train_weights=None)


def within_part(part: Part, block_s: float = BLOCK_S) -> Part:
    """
    Return ``part`` with each sample's block mean taken off, segments cut at block edges.

    The blocks are the population fit's (:func:`~gps_error_ros.fit.population_fit.block_ids`:
    each run cut from its own first sample), so that no block mixes two runs' biases.
    """
    pieces = block_pieces(part.err, part.t, block_s, alongside=(part.truth, part.t))
    means = block_means(pieces)
    out = Part([], [], [])
    for e, i, truth, t in pieces:
        out.err.append(e - means[i])
        out.truth.append(truth)
        out.t.append(t)
    return out


def _kalman_ll(part: Part, a: int, phi: FloatArray, sigma_w: float, mean: float,
               bias_sd: float, rate: float, held_sd: float = 0.0) -> FloatArray:
    """
    Return the one-step log densities of axis ``a`` of every sample of ``part``.

    The state: the AR's ``p`` lags, the wandering bias (factor ``rate`` per
    step, SD ``bias_sd``) and, with ``held_sd``, the part of the bias held
    for the run.
    """
    phi = phi if phi.size else np.zeros(1)
    p = phi.size
    n = p + 2 if held_sd > 0 else p + 1
    f = np.zeros((n, n))
    f[0, :p] = phi
    f[1:p, :p - 1] = np.eye(p - 1)
    f[p, p] = rate
    q = np.zeros((n, n))
    q[0, 0] = sigma_w ** 2
    q[p, p] = (1.0 - rate ** 2) * bias_sd ** 2
    h = np.zeros(n)
    h[0] = h[p] = 1.0
    model = ARErrorModel(*(AxisParams(0.0, tuple(phi), sigma_w),) * 2)
    p0 = np.zeros((n, n))
    acv = model.autocovariance(p)[:, 0, 0]
    p0[:p, :p] = acv[np.abs(np.subtract.outer(np.arange(p), np.arange(p)))]
    p0[p, p] = bias_sd ** 2
    if held_sd > 0:
        f[p + 1, p + 1] = h[p + 1] = 1.0
        p0[p + 1, p + 1] = held_sd ** 2
    x, cov = np.zeros(n), p0
    t = np.concatenate(part.t)
    y = np.concatenate(part.err)[:, a] - mean
    out = np.empty(y.size)
    for i in range(y.size):
        if i:
            for _ in range(max(1, int(round(t[i] - t[i - 1])))):
                x, cov = f @ x, f @ cov @ f.T + q
        s = float(h @ cov @ h)
        nu = y[i] - float(h @ x)
        out[i] = -0.5 * (np.log(2 * np.pi * s) + nu * nu / s)
        gain = cov @ h / s
        x, cov = x + gain * nu, cov - np.outer(gain, h @ cov)
    return out

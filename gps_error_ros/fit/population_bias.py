"""
How a population's bias spreads between blocks, and what a new run's bias is predicted to be.

The steps 3, 5 and 6 of :mod:`~gps_error_ros.fit.population_fit`: the
blocks' chains (runs of neighbouring blocks), the neighbours' covariance
and the time constant it gives, the bias on two time scales (a part held
for the run, a wander), how many independent draws the blocks hold, and
the predictive factors that write the section for a run the fit did not
see. The blocks are :class:`Block`s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from gps_error_ros.fit.population_evidence import (PopulationEvidence, TimeConstant,
                                                   TwoScaleSpreads)
from gps_error_ros.model.population import MAX_BIAS_DOF, Population
from gps_error_ros.model.state import FloatArray


@dataclass(frozen=True)
class Block:
    """One block: its samples (n, 2), its first and last sample time, and its weight."""

    err: np.ndarray
    t0: float
    t1: float
    weight: float = 1.0


#: Neighbour pairs a time constant needs.
MIN_PAIRS = 3
#: Neighbours' correlation at and above which the bias is taken as constant for a run.
CONSTANT_R = 0.95
#: Passes of the two-scale fit's fixed point (wander and held SDs, neighbours' correlation).
TWO_SCALE_PASSES = 20
#: Largest gap between neighbouring blocks, s.
ADJACENT_GAP_S = 60.0
#: The smallest neighbours' correlation a time constant takes: one block's decay. Below
#: it the bias changes within a block, and blocks of that length cannot say how fast.
FLOOR_R = math.exp(-1.0)


def bias_section(blocks: Sequence[Block], bias_sd: FloatArray, tau: Optional[float],
                 r: Optional[float],
                 two: Optional[tuple[FloatArray, FloatArray, float, TwoScaleSpreads]],
                 scale_sd: float, block_s: float, evidence: PopulationEvidence,
                 r_estimate: Optional[float] = None) -> Population:
    """
    Return the :class:`Population` of one bias part or of two (``two``); add to ``evidence``.

    ``r``: the neighbours' correlation that gave the time constant ``tau``
    (``r_estimate``: as estimated, before its bounds);
    ``two``: :func:`two_scale_bias`'s (wander SD, held SD, ``a``, evidence) or None.
    """
    if two is not None:
        wander_sd, held_sd, a, spreads = two
        draws = independent_draws(blocks)
        dof, inflate = predictive(draws)
        contrasts = wander_contrasts(blocks)
        evidence.update(spreads)
        evidence['wander_sd_estimate_m'] = [round(float(x), 4) for x in wander_sd]
        evidence['wander_contrasts'] = round(contrasts, 3)
        evidence['held_sd_estimate_m'] = [round(float(x), 4) for x in held_sd]
        evidence['independent_draws'] = round(draws, 3)
        spread = variance_predictive(contrasts)
        evidence['bias_time_constant'] = time_constant_evidence(
            spreads['wander_correlation_estimate'], a, evidence['neighbour_pairs'], block_s)
        return Population(tuple(float(x) * spread for x in wander_sd), scale_sd,
                          _tau(a, block_s), dof,
                          tuple(float(x) * inflate for x in held_sd))
    draws = independent_draws(blocks, None if tau is None else r)
    dof, inflate = predictive(draws)
    evidence['bias_sd_estimate_m'] = [round(float(x), 4) for x in bias_sd]
    evidence['independent_draws'] = round(draws, 3)
    if tau is not None and r is not None:
        evidence['bias_time_constant'] = time_constant_evidence(
            r if r_estimate is None else r_estimate, r, evidence['neighbour_pairs'], block_s)
    return Population(tuple(float(x) * inflate for x in bias_sd), scale_sd, tau, dof)


def chains_of(blocks: Sequence[Block]) -> list[list[int]]:
    """Return the blocks' indices cut into chains: runs of blocks less than a gap apart."""
    chains = [[0]] if blocks else []
    for j in range(1, len(blocks)):
        if blocks[j].t0 - blocks[j - 1].t1 <= ADJACENT_GAP_S:
            chains[-1].append(j)
        else:
            chains.append([j])
    return chains


def neighbour_pairs(blocks: Sequence[Block]) -> list[int]:
    """Return the indices ``j`` of the blocks whose successor ``j + 1`` lies in their chain."""
    return [j for chain in chains_of(blocks) for j in chain[:-1]]


def neighbour_cov_beyond(blocks: Sequence[Block], dev: FloatArray, process_cov: FloatArray,
                         pairs: Sequence[int]) -> Optional[FloatArray]:
    """
    Return the neighbours' covariance of mean deviations per axis (2,), or None without pairs.

    ``process_cov``: per block, the covariance with its successor's mean
    that the within process alone gives
    (:func:`~gps_error_ros.fit.population_fit.neighbour_covariance`), taken
    off; the pairs weigh as their first blocks.
    """
    if not pairs:
        return None
    return np.average([dev[j] * dev[j + 1] - process_cov[j] for j in pairs], axis=0,
                      weights=[blocks[j].weight for j in pairs])


def two_scale_bias(blocks: Sequence[Block], dev: FloatArray, v: FloatArray,
                   near: Optional[FloatArray],
                   a: float) -> Optional[tuple[FloatArray, FloatArray, float, TwoScaleSpreads]]:
    """
    Return (wander SD (2,), held SD (2,), ``a``, evidence) of a bias on two time scales, or None.

    ``dev``: the blocks' mean deviations from the grand mean (k, 2); ``v``:
    what the process within gives each block's mean as variance (k, 2);
    ``near``: the neighbours' covariance beyond the process's
    (:func:`neighbour_cov_beyond`); ``a``: the neighbours' correlation of the
    one-part fit, a start. See
    step 6 of :mod:`~gps_error_ros.fit.population_fit`. The evidence: the SD of the chains'
    means and the pooled SD of the block means within a chain, per axis. None
    where the chains cannot tell the
    two parts apart: fewer than two chains (counted by their weights), none
    of two blocks or more, or either part nil on both axes.
    """
    chains = chains_of(blocks)
    w = np.array([blocks[ch[0]].weight for ch in chains])
    m = np.array([len(ch) for ch in chains], dtype=float)
    if near is None or w.sum() < 2.0 or m.max() < 2:
        return None
    means = np.array([dev[ch].mean(axis=0) for ch in chains])
    ssw = sum(wi * ((dev[ch] - mu) ** 2).sum(axis=0) for wi, ch, mu in zip(w, chains, means))
    vbar = np.array([v[ch].mean(axis=0) for ch in chains])
    centre = np.average(means, axis=0, weights=w)
    spread = (w[:, None] * (means - centre) ** 2).sum(axis=0) / (w.sum() - 1.0)
    d = [np.arange(1, k) for k in m.astype(int)]
    for _ in range(TWO_SCALE_PASSES):
        s = np.array([k + 2.0 * float(np.sum((k - dd) * a ** dd)) for k, dd in zip(m, d)])
        wander = np.maximum(0.0, (ssw - (w * (m - 1.0)) @ vbar) / float(np.sum(w * (m - s / m))))
        held = np.maximum(0.0, spread - np.average(wander[None] * (s / m ** 2)[:, None] +
                                                   vbar / m[:, None], axis=0, weights=w))
        if not np.any(wander > 0):
            return None
        estimate = float((np.sum(near) - np.sum(held)) / np.sum(wander))
        a = float(np.clip(estimate, FLOOR_R, CONSTANT_R))
    if not np.any(held > 0):
        return None
    within = ssw / float(np.sum(w * (m - 1.0)))
    return np.sqrt(wander), np.sqrt(held), a, {
        'run_means_sd_m': [round(float(x), 4) for x in np.sqrt(spread)],
        'block_means_within_run_sd_m': [round(float(x), 4) for x in np.sqrt(within)],
        'wander_correlation_estimate': round(estimate, 4)}


def independent_draws(blocks: Sequence[Block], r: Optional[float] = None) -> float:
    """
    Return how many independent draws of the bias ``blocks`` hold, counted by their weights.

    Blocks less than :data:`ADJACENT_GAP_S` apart form a chain (one run).
    With ``r`` None (a bias constant for a run) a chain is one draw; with a
    bias whose neighbouring blocks correlate by ``r``, a chain of ``m`` is
    ``m^2 / (m + 2 sum_j (m - j) r^j)`` draws (as many as its mean is worth).
    """
    total = 0.0
    for chain in chains_of(blocks):
        m = len(chain)
        if r is None:
            n = 1.0
        else:
            j = np.arange(1, m)
            n = m * m / (m + 2.0 * float(np.sum((m - j) * r ** j)))
        total += blocks[chain[0]].weight * n
    return total


def wander_contrasts(blocks: Sequence[Block]) -> float:
    """
    Return the blocks' contrasts within their chains, ``sum (m - 1)``, counted by the weights.

    A chain of ``m`` neighbouring blocks (one run) holds ``m - 1``
    deviations of its blocks' means from its own mean: what the wander's
    variance is estimated from (step 6 of :mod:`~gps_error_ros.fit.population_fit`).
    """
    return float(sum(blocks[ch[0]].weight * (len(ch) - 1) for ch in chains_of(blocks)))


def variance_predictive(dof: float) -> float:
    """
    Return the factor on an SD estimated from ``dof`` degrees of freedom, for a new draw.

    The SD of a Student-t with ``dof`` degrees of freedom (rounded, at least
    3) over its scale, ``sqrt(dof / (dof - 2))``: a new draw of a normal
    whose variance is estimated, with the estimate as the law's scale; 1
    beyond :data:`~gps_error_ros.model.population.MAX_BIAS_DOF`.
    """
    dof = max(3, int(round(dof)))
    return 1.0 if dof > MAX_BIAS_DOF else math.sqrt(dof / (dof - 2.0))


def predictive(draws: float) -> tuple[Optional[int], float]:
    """
    Return (degrees of freedom or None, the factor on the bias SD) for a new occasion.

    See step 5 of :mod:`~gps_error_ros.fit.population_fit`: ``dof = max(3, round(k - 1))`` and
    ``sqrt(1 + 1 / k) sqrt(dof / (dof - 2))``; None and ``sqrt(1 + 1 / k)``
    above :data:`~gps_error_ros.model.population.MAX_BIAS_DOF`.
    """
    k = max(draws, 1.0)
    location = math.sqrt(1.0 + 1.0 / k)
    dof = max(3, int(round(k - 1.0)))
    if dof > MAX_BIAS_DOF:
        return None, location
    return dof, location * variance_predictive(dof)


def neighbour_correlation(pairs: int, near: Optional[FloatArray],
                          between: FloatArray) -> Optional[float]:
    """
    Return the neighbours' correlation as estimated, or None.

    ``pairs``: how many neighbour pairs; ``near``: their covariance beyond
    the process's, per axis (:func:`neighbour_cov_beyond`); the correlation is
    taken over the axes whose bias variance ``between`` is not nil. None
    with fewer than :data:`MIN_PAIRS` pairs or no bias.
    """
    if near is None or pairs < MIN_PAIRS or not np.any(between > 0):
        return None
    w = between > 0
    return float(np.sum(near[w]) / np.sum(between[w]))


def time_constant(pairs: int, near: Optional[FloatArray], between: FloatArray,
                  block_s: float) -> tuple[Optional[float], Optional[float]]:
    """
    Return (time constant s or None, the neighbours' correlation used or None).

    The time constant whose block means correlate as the neighbours' do
    (:func:`block_mean_correlation`), of the correlation of
    :func:`neighbour_correlation`; at or above
    :data:`CONSTANT_R` the bias is constant for a run (no time constant).
    Below :data:`FLOOR_R` (one block's decay) the bias changes within a
    block, faster than blocks of ``block_s`` can measure: the time constant
    taken is that of ``FLOOR_R``, an upper bound of the estimate
    (:func:`time_constant_evidence` says so), and the AR within the blocks
    carries what is faster.
    """
    r = neighbour_correlation(pairs, near, between)
    if r is None:
        return None, None
    if r >= CONSTANT_R:
        return None, r
    r = max(r, FLOOR_R)
    return float(_tau(r, block_s)), r


def block_mean_correlation(x: float) -> float:
    """
    Return the correlation of neighbouring block means of a bias with ``x`` = block / tau.

    A first-order Gauss-Markov bias (the model's wander, tau its time
    constant) averaged over neighbouring blocks of length ``B``: their means
    correlate by ``(1 - e^-x)^2 / (2 (x - 1 + e^-x))``, ``x = B / tau``,
    more than the bias's own ``e^-x`` at one block's distance (an average
    smooths). 1 at ``x`` -> 0, about ``1 / (2 x)`` for large ``x``.
    """
    if x < 1e-4:                 # the series: 1 - x / 3 + ...
        return 1.0 - x / 3.0
    return math.expm1(-x) ** 2 / (2.0 * (x + math.expm1(-x)))


def _tau(r: float, block_s: float) -> float:
    """
    Return the time constant (s) whose neighbouring block means correlate by ``r``.

    The inverse of :func:`block_mean_correlation` (it falls as ``x`` grows),
    by bisection on ``log x``; 0 at ``r <= 0``, inf at ``r >= 1``.
    """
    if r <= 0.0:
        return 0.0
    if r >= 1.0:
        return math.inf
    lo, hi = -12.0, 12.0             # log x: the correlation from 1 - 2e-6 to 1e-5
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if block_mean_correlation(math.exp(mid)) > r:
            lo = mid
        else:
            hi = mid
    return block_s / math.exp(0.5 * (lo + hi))


def time_constant_evidence(estimate: float, used: float, pairs: int,
                           block_s: float) -> TimeConstant:
    """
    Return what the fit knows of the bias's time constant, for the profile's ``fit`` section.

    ``estimate``: the neighbours' correlation as estimated; ``used``: as
    taken (bounded to [:data:`FLOOR_R`, :data:`CONSTANT_R`]); ``pairs``: the
    neighbour pairs it came from. ``kind`` is ``estimate`` where the value
    is the estimate's, ``upper bound`` where the estimate was below one
    block's decay (the value is the block length; the estimate's own is
    ``estimate_s``). ``interval_95_s`` is an approximate 95 % interval of the
    estimate: Fisher's z on the pairs, as if independent (they overlap, so
    it is too narrow if anything); 0 and ``inf`` where it reaches a
    correlation of 0 or 1.
    """
    z, se = math.atanh(max(-0.999, min(0.999, estimate))), 1.0 / math.sqrt(max(pairs - 3, 1))
    lo, hi = math.tanh(z - 1.96 * se), math.tanh(z + 1.96 * se)
    kind = 'upper bound' if estimate < FLOOR_R else 'estimate'
    return {'value_s': round(_tau(used, block_s), 1), 'kind': kind,
            'correlation_estimate': round(float(estimate), 4),
            'estimate_s': round(_tau(estimate, block_s), 1),
            'interval_95_s': [round(_tau(lo, block_s), 1),
                              round(_tau(hi, block_s), 1) if hi < 1.0 else 'inf'],
            'resolution_s': float(block_s)}


def time_constant_words(evidence: PopulationEvidence) -> str:
    """Return how a line or page states the bias's time constant from its evidence."""
    tc = evidence['bias_time_constant']
    lo, hi = tc['interval_95_s']
    hi = 'no upper end' if hi == 'inf' else f'{hi:.0f} s'
    if tc['kind'] == 'upper bound':
        return (f'a time constant of at most {tc["value_s"]:.0f} s (a bound, not a fit: the '
                f'means of neighbouring blocks of {tc["resolution_s"]:.0f} s correlate by '
                f'{tc["correlation_estimate"]:.2f}, less than {FLOOR_R:.2f}, so the bias '
                f'changes faster than the blocks resolve; 95 % interval {lo:.0f} s to {hi})')
    return (f'a time constant of {tc["value_s"]:.0f} s (95 % interval {lo:.0f} s to {hi}, '
            f'from {tc["correlation_estimate"]:.2f} between neighbouring blocks)')

"""
How a population's bias spreads between blocks, and what a new run's bias is predicted to be.

The steps 3, 5 and 6 of :mod:`~gps_error_ros.fit.population_fit`: the
blocks' chains (runs of neighbouring blocks), the neighbours' covariance
and the time constant it gives, the bias on two time scales (a part held
for the run, a wander), how many independent draws the blocks hold, and
the predictive factors that write the section for a run the fit did not
see. The blocks are :class:`~gps_error_ros.fit.population_fit.Block`s.
"""

import math

import numpy as np

from gps_error_ros.model.population import MAX_BIAS_DOF, Population

#: Neighbour pairs a time constant needs.
MIN_PAIRS = 3
#: Neighbours' correlation at and above which the bias is taken as constant for a run.
CONSTANT_R = 0.95
#: Passes of the two-scale fit's fixed point (wander and held SDs, neighbours' correlation).
TWO_SCALE_PASSES = 20
#: Largest gap between neighbouring blocks, s.
ADJACENT_GAP_S = 60.0


def bias_section(blocks, bias_sd, tau, r, two, scale_sd, block_s, evidence):
    """
    Return the :class:`Population` of one bias part or of two (``two``); add to ``evidence``.

    ``r``: the neighbours' correlation that gave the time constant ``tau``;
    ``two``: :func:`two_scale_bias`'s (wander SD, held SD, ``a``, evidence) or None.
    """
    if two is not None:
        wander_sd, held_sd, a, spreads = two
        draws = independent_draws(blocks)
        dof, inflate = predictive(draws)
        contrasts = wander_contrasts(blocks)
        evidence.update(spreads, wander_sd_estimate_m=[round(float(x), 4) for x in wander_sd],
                        wander_contrasts=round(contrasts, 3),
                        held_sd_estimate_m=[round(float(x), 4) for x in held_sd],
                        independent_draws=round(draws, 3))
        spread = variance_predictive(contrasts)
        return Population(tuple(float(x) * spread for x in wander_sd), scale_sd,
                          float(-block_s / math.log(a)), dof,
                          tuple(float(x) * inflate for x in held_sd))
    draws = independent_draws(blocks, None if tau is None else r)
    dof, inflate = predictive(draws)
    evidence.update(bias_sd_estimate_m=[round(float(x), 4) for x in bias_sd],
                    independent_draws=round(draws, 3))
    return Population(tuple(float(x) * inflate for x in bias_sd), scale_sd, tau, dof)


def chains_of(blocks):
    """Return the blocks' indices cut into chains: runs of blocks less than a gap apart."""
    chains = [[0]] if blocks else []
    for j in range(1, len(blocks)):
        if blocks[j].t0 - blocks[j - 1].t1 <= ADJACENT_GAP_S:
            chains[-1].append(j)
        else:
            chains.append([j])
    return chains


def neighbour_pairs(blocks):
    """Return the indices ``j`` of the blocks whose successor ``j + 1`` lies in their chain."""
    return [j for chain in chains_of(blocks) for j in chain[:-1]]


def neighbour_cov_beyond(blocks, dev, process_cov, pairs):
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


def two_scale_bias(blocks, dev, v, near, a):
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
    if w.sum() < 2.0 or m.max() < 2:
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
        a = float(np.clip((np.sum(near) - np.sum(held)) / np.sum(wander), math.exp(-1.0),
                          CONSTANT_R))
    if not np.any(held > 0):
        return None
    within = ssw / float(np.sum(w * (m - 1.0)))
    return np.sqrt(wander), np.sqrt(held), a, {
        'run_means_sd_m': [round(float(x), 4) for x in np.sqrt(spread)],
        'block_means_within_run_sd_m': [round(float(x), 4) for x in np.sqrt(within)]}


def independent_draws(blocks, r=None):
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


def wander_contrasts(blocks):
    """
    Return the blocks' contrasts within their chains, ``sum (m - 1)``, counted by the weights.

    A chain of ``m`` neighbouring blocks (one run) holds ``m - 1``
    deviations of its blocks' means from its own mean: what the wander's
    variance is estimated from (step 6 of :mod:`~gps_error_ros.fit.population_fit`).
    """
    return float(sum(blocks[ch[0]].weight * (len(ch) - 1) for ch in chains_of(blocks)))


def variance_predictive(dof):
    """
    Return the factor on an SD estimated from ``dof`` degrees of freedom, for a new draw.

    The SD of a Student-t with ``dof`` degrees of freedom (rounded, at least
    3) over its scale, ``sqrt(dof / (dof - 2))``: a new draw of a normal
    whose variance is estimated, with the estimate as the law's scale; 1
    beyond :data:`~gps_error_ros.model.population.MAX_BIAS_DOF`.
    """
    dof = max(3, int(round(dof)))
    return 1.0 if dof > MAX_BIAS_DOF else math.sqrt(dof / (dof - 2.0))


def predictive(draws):
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


def time_constant(pairs, near, between, block_s):
    """
    Return (time constant s or None, the neighbours' correlation or None).

    ``pairs``: how many neighbour pairs; ``near``: their covariance beyond
    the process's, per axis (:func:`neighbour_cov_beyond`); the correlation is
    taken over the axes whose bias variance ``between`` is not nil.
    """
    if pairs < MIN_PAIRS or not np.any(between > 0):
        return None, None
    w = between > 0
    r = float(np.sum(near[w]) / np.sum(between[w]))
    if r >= CONSTANT_R:
        return None, r
    r = max(r, math.exp(-1.0))          # at most one block's decay per block: the AR covers less
    return float(-block_s / math.log(r)), r

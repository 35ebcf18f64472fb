"""
Fit a population profile: the error process within stretches, and how stretches differ.

A phone's error over one stretch has a bias and a scale of its own; over
another stretch, another day or in another phone of the kind, they differ.
The fit cuts the recordings into blocks of :data:`BLOCK_S` seconds (a
recording's own blocks, and every recording's: several recordings of one
receiver are several runs) and separates what happens within a block from
what differs between blocks:

1. **Within**: the AR process is fitted (Yule-Walker, order by the PACF, as
   ``calibrate``) on the errors about each block's own mean, pooled over
   blocks, with the autocovariance that the block means took away given
   back (:func:`fit_within`). Its mean is the grand mean of every sample.
2. **Bias**: the variance of the block means about the grand mean, less
   what the within process alone gives a mean of that many samples
   (``gamma0 (1 + 2 sum (1 - k/n) rho_k) / n``), per axis, floored at 0:
   ``bias_sd_m``, by the method of moments.
3. **Time constant**: blocks next to each other (less than
   :data:`ADJACENT_GAP_S` apart) share their bias to a degree: the
   correlation ``r`` of neighbours' mean deviations (their covariance less
   what the within process gives, over the bias variance) gives
   ``bias_time_constant_s = -BLOCK_S / ln r``. At ``r >=`` ``CONSTANT_R``,
   or with fewer than ``MIN_PAIRS`` neighbour pairs, the bias is
   constant for a run (no time constant). Below ``FLOOR_R = e^-1`` (one
   block's decay) the bias changes within a block, faster than the blocks
   resolve: the time constant is set to the block length and the fit's
   evidence (``bias_time_constant``) calls it an upper bound, not a fit,
   with the estimate and an approximate 95 % interval beside it.
4. **Scale**: the variance of each block's log SD (averaged over the axes)
   less its sampling variance under the within process (``(1 + 2 sum
   rho_k^2) / (4 n)``), floored at 0: ``scale_sd_log``.
5. **A new occasion's bias**: the blocks are ``k`` independent draws of the
   bias at most (``independent_draws``: a chain of neighbouring blocks
   counts as one draw when the bias is constant for a run, and as fewer
   than its blocks when it wanders). The bias of a run the fit did not see
   is predicted as a normal sample's next draw is when its mean and SD are
   both estimated from ``k`` draws: Student-t with ``k - 1`` degrees of
   freedom (rounded, at least 3 so that its SD exists), scale
   ``s sqrt(1 + 1 / k)``, ``s`` the SD of step 2. ``bias_sd_m`` is that
   distribution's SD, ``s sqrt(1 + 1 / k) sqrt(dof / (dof - 2))``, and
   ``bias_dof`` its degrees of freedom; beyond
   :data:`~gps_error_ros.model.population.MAX_BIAS_DOF` the bias is normal
   with SD ``s sqrt(1 + 1 / k)``.

6. **Two time scales**: where the bias wanders (step 3) and the blocks
   lie in two chains or more (runs of neighbouring blocks, counted by
   their weights), the bias may have a part held for the run beside the
   wander (``two_scale_bias``): the spread of the block means within a
   chain is the wander's (less what the process gives), the spread of the
   chains' means beyond what the wander and the process give a chain's mean
   is the held part's, and the neighbours' covariance, less the held part's
   variance, over the wander's gives the wander's correlation; the three
   are solved together by ``TWO_SCALE_PASSES`` passes from step 3's
   correlation. A run's held part is one draw per chain: step 5 predicts
   it from the chains (``run_bias_sd_m``, Student-t). The wander's
   variance is estimated from the blocks' deviations within their chains,
   ``nu = sum (m - 1)`` contrasts (a chain of ``m`` blocks, counted by its
   weight; ``wander_contrasts``), and is predicted as step 5 predicts
   the held part's, for the variance alone (its mean is nil within a run):
   ``bias_sd_m`` is the estimate times ``sqrt(nu / (nu - 2))``, ``nu``
   rounded and at least 3, the estimate itself beyond
   :data:`~gps_error_ros.model.population.MAX_BIAS_DOF`; both parts take the
   same Student-t factor. Where the
   chains cannot tell the parts apart (one chain, no chain of two blocks, or
   either part nil on both axes) the bias is the one part of steps 2-5.

Recordings made together (several receivers carried on one walk, phones in
one car) share their environment, and so their bias: they are one
*occasion*, one draw of the population, not several. :func:`occasions`
finds them from the recordings' truths (the same track at the same time
from the start, within :data:`OCCASION_M`, allowing a start offset of up to

:data:`OCCASION_LAG_S`; a truth that stays within :data:`OCCASION_TRACK_M`
of its start says nothing of when it was recorded, so standing recordings
are each an occasion of their own); each block then weighs ``1 / k``, ``k`` the
recordings of its occasion, in every moment above (the grand mean too), so
that an occasion counts once however many receivers recorded it.

Steps 3, 5 and 6 are computed in :mod:`~gps_error_ros.fit.population_bias`,
where ``CONSTANT_R``, ``MIN_PAIRS``, ``TWO_SCALE_PASSES``,
``independent_draws``, ``two_scale_bias`` and ``wander_contrasts`` live.

Fewer than :data:`MIN_BLOCKS` blocks of at least :data:`MIN_BLOCK_SAMPLES`
samples (counted by their weights): no population is fitted, and the
reason says so.
"""

from dataclasses import dataclass, replace
import math

import numpy as np
from typing import Any, Optional, Sequence

from gps_error_ros.fit.autocorrelation import pooled_autocovariance
from gps_error_ros.fit.population_evidence import PopulationEvidence
from gps_error_ros.fit.population_bias import (ADJACENT_GAP_S, bias_section, Block,
                                               neighbour_correlation, neighbour_cov_beyond,
                                               neighbour_pairs, time_constant,
                                               time_constant_words, two_scale_bias)
from gps_error_ros.fit.yule_walker import DEFAULT_MAX_ORDER, fit_axis, solve_yule_walker
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams, AXES, ModelError
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.population import Population
from gps_error_ros.traces.trace_io import recording_offsets, Trace
from gps_error_ros.model.state import FloatArray, IntArray, Numbers

#: Block length, s: the stretch whose bias and scale one run is taken to have.
BLOCK_S = 300.0
#: Samples a block needs to count.
MIN_BLOCK_SAMPLES = 60
#: Blocks a population needs.
MIN_BLOCKS = 3
#: Lags of the within process's ACF used for a block mean's variance.
ACF_LAGS = 600
#: Passes of the within fit's correction for the block means taken out.
CORRECTIONS = 8
#: Median distance between two recordings' truths (m) within which they are one occasion
#: (one person or one car carries the receivers; walks of one route lie 5 m and more apart).
OCCASION_M = 2.0
#: Largest offset between the starts of two recordings of one occasion, s.
OCCASION_LAG_S = 10
#: Share of the shorter recording's span the two must overlap for one occasion.
OCCASION_OVERLAP = 0.8
#: How far (m) a recording's truth must move from its start to tell an occasion by it.
OCCASION_TRACK_M = 50.0


def block_ids(times: Sequence[Numbers], block_s: float = BLOCK_S) -> list[IntArray]:
    """
    Return each sample's block number, one array per segment of ``times``.

    A run is a stretch of samples without a gap over :data:`ADJACENT_GAP_S`
    (recordings joined one after another are separate runs); each run is
    cut on a grid of ``block_s`` from its own first sample, so that no block
    holds samples of two runs.
    """
    flat = np.concatenate([np.asarray(x, dtype=float) for x in times])
    order = np.argsort(flat, kind='stable')
    t = flat[order]
    run = np.r_[0, np.cumsum(np.diff(t) > ADJACENT_GAP_S)]
    starts = np.flatnonzero(np.r_[True, np.diff(run) != 0])
    local = np.floor((t - t[starts][run]) / block_s).astype(np.int64)
    last = np.maximum.reduceat(local, starts)
    offset = np.r_[0, np.cumsum(last + 1)[:-1]]
    ids = np.empty(t.size, dtype=np.int64)
    ids[order] = local + offset[run]
    return np.split(ids, np.cumsum([len(x) for x in times])[:-1])


def blocks_of(segments: Sequence[Numbers], times: Sequence[Numbers], block_s: float = BLOCK_S,
              weights: Optional[Sequence[float]] = None) -> list[Block]:
    """
    Return the :class:`Block` list of error segments with their times.

    ``segments``: (n_s, 2) north/east errors; ``times``: (n_s,) seconds;
    ``weights``: each segment's weight (default 1). Blocks are those of
    :func:`block_ids`; a block holds the samples of every segment that fall
    in it, and the weight of its first sample's.
    """
    weights = [1.0] * len(segments) if weights is None else weights
    t = np.concatenate([np.asarray(x, dtype=float) for x in times])
    e = np.concatenate([np.asarray(x, dtype=float) for x in segments])
    w = np.concatenate([np.full(len(x), float(v)) for x, v in zip(times, weights)])
    ids = np.concatenate(block_ids(times, block_s))
    order = np.argsort(t, kind='stable')
    t, e, w, ids = t[order], e[order], w[order], ids[order]
    cuts = np.flatnonzero(np.diff(ids) != 0) + 1
    return [Block(ee, float(tt[0]), float(tt[-1]), float(ww[0]))
            for ee, tt, ww in zip(np.split(e, cuts), np.split(t, cuts), np.split(w, cuts))]


def _same_track(a: Trace, b: Trace) -> bool:
    """Return whether recordings ``a`` and ``b`` follow one truth at one time (see the doc)."""
    span = min(a.t[-1] - a.t[0], b.t[-1] - b.t[0])
    if span <= 0:
        return False
    ta, tb = a.t - a.t[0], b.t - b.t[0]
    north, east = difference(a.truth_lat, a.truth_lon, a.truth_lat[0], a.truth_lon[0])
    if np.max(np.hypot(north, east)) < OCCASION_TRACK_M:
        return False            # a standing receiver's truth does not say when it recorded
    for lag in range(-OCCASION_LAG_S, OCCASION_LAG_S + 1):
        both = (ta + lag >= tb[0]) & (ta + lag <= tb[-1])
        t = ta[both]
        if t.size < 2 or t[-1] - t[0] < OCCASION_OVERLAP * span:
            continue
        lat = np.interp(t + lag, tb, b.truth_lat)
        lon = np.interp(t + lag, tb, b.truth_lon)
        north, east = difference(a.truth_lat[both], a.truth_lon[both], lat, lon)
        if np.median(np.hypot(north, east)) <= OCCASION_M:
            return True
    return False


def occasions(traces: Sequence[Trace]) -> list[int]:
    """
    Return each recording's occasion, a list of ints from 0 in order of appearance.

    A recording joins the occasion of the first earlier one whose truth
    follows the same track at the same time (:func:`_same_track`).
    """
    label = list(range(len(traces)))
    for j in range(len(traces)):
        for i in range(j):
            if label[j] == j and _same_track(traces[i], traces[j]):
                label[j] = label[i]
    first = {v: k for k, v in enumerate(dict.fromkeys(label))}
    return [first[v] for v in label]


def segment_weights(traces: Sequence[Trace], times: Sequence[Numbers]) -> list[float]:
    """
    Return each segment's weight, ``1 / k`` for a recording one of ``k`` of its occasion.

    ``traces``: the recordings as joined (:func:`~gps_error_ros.traces.trace_io.join_recordings`);
    ``times``: each segment's sample times in the joined time line, s.
    """
    labels = occasions(traces)
    weight = [1.0 / labels.count(v) for v in labels]
    starts = recording_offsets(traces)
    return [weight[int(np.searchsorted(starts, float(t[0]), side='right')) - 1]
            for t in times]


def mean_variance(rho: FloatArray, n: int, gamma0: Any) -> Any:
    """Return the variance of the mean of ``n`` samples of a process (ACF ``rho`` from lag 0)."""
    k = np.arange(1, min(n, rho.size))
    return gamma0 * (1.0 + 2.0 * np.sum((1.0 - k / n) * rho[k])) / n


def neighbour_covariance(rho: FloatArray, n: int, gamma0: Any) -> Any:
    """Return the covariance of the means of two adjacent blocks of ``n`` samples of a process."""
    k = np.arange(1, 2 * n)
    k = k[k < rho.size]
    return gamma0 * float(np.sum(np.minimum(k, 2 * n - k) * rho[k])) / (n * n)


@dataclass(frozen=True)
class PopulationFit:
    """The fit: the within AR per axis (:class:`AxisParams`), the section (or None), evidence."""

    north: AxisParams
    east: AxisParams
    mean: np.ndarray
    population: Optional[Population]
    evidence: PopulationEvidence

    def axis_params(self) -> tuple[AxisParams, AxisParams]:
        """Return the within AR as (north, east) :class:`AxisParams`, delta for the grand mean."""
        north, east = (AxisParams((1.0 - float(np.sum(p.phi))) * float(m), p.phi, p.sigma_w)
                       for p, m in zip((self.north, self.east), self.mean))
        return north, east


def fit_within(pieces: Sequence[FloatArray], sizes: Sequence[int], order: Optional[int] = None,
               max_order: int = DEFAULT_MAX_ORDER, axis: str = 'axis') -> AxisParams:
    """
    Return the within process of one axis (:class:`AxisParams`, delta 0) from demeaned pieces.

    ``pieces``: the errors about their block's mean; ``sizes``: the blocks'
    sample counts. About its own mean a block's autocovariance is short by
    the variance of that mean, so the pooled autocovariance gets it back:
    ``v`` (the mean over blocks of :func:`mean_variance` under the current
    fit) is added at every lag and the fit repeated, :data:`CORRECTIONS`
    times (``v`` at most the uncorrected variance). The order is the PACF's
    choice on the uncorrected autocovariance, as ``calibrate``'s.
    """
    first = fit_axis(pieces, order, max_order, axis=axis)
    p = first.params.order
    raw, _, _ = pooled_autocovariance(pieces, max(p, 1), mean=0.0)
    params = AxisParams(0.0, first.params.phi, first.params.sigma_w)
    for _ in range(CORRECTIONS):
        model = ARErrorModel(params, params)
        rho = model.autocorrelation(ACF_LAGS)[:, 0]
        gamma0 = float(model.stationary_cov[0, 0])
        v = min(float(np.mean([mean_variance(rho, k, gamma0) for k in sizes])), raw[0])
        try:
            phi, var = solve_yule_walker(raw + v, p)
            params = AxisParams(0.0, tuple(phi), float(np.sqrt(var)))
        except ModelError:
            break
    return params


def fit_population(segments: Sequence[Numbers], times: Sequence[Numbers],
                   order: Optional[int] = None, max_order: int = DEFAULT_MAX_ORDER,
                   block_s: float = BLOCK_S, weights: Optional[Sequence[float]] = None,
                   two_scales: bool = True) -> PopulationFit:
    """
    Fit the within process and the population (see the module docstring).

    Parameters
    ----------
    segments
        North/east errors (n_s, 2) of each gap-free segment, every recording.
    times
        Each segment's sample times, s (recordings one after another).
    order
        The AR order of both axes (default: chosen per axis by the PACF).
    max_order
        The largest order the PACF may choose.
    block_s
        The block length, s.
    weights
        Each segment's weight: ``1 / k`` for a recording one of ``k`` of its
        occasion (:func:`segment_weights`); default 1 each.
    two_scales
        Whether the bias may have a part held for the run beside its
        wander (step 6 of the module docstring).

    Returns
    -------
    PopulationFit

    """
    weights = [1.0] * len(segments) if weights is None else list(weights)
    blocks = [b for b in blocks_of(segments, times, block_s, weights)
              if len(b.err) >= MIN_BLOCK_SAMPLES]
    grand = sum(w * np.asarray(s, dtype=float).sum(axis=0)
                for s, w in zip(segments, weights)) / sum(
                    w * len(s) for s, w in zip(segments, weights))
    within, sizes = _within_segments(segments, times, block_s)
    axes = [fit_within([s[:, a] for s in within], sizes, order, max_order, axis=ax)
            for a, ax in enumerate(AXES)]
    wb = np.array([b.weight for b in blocks])
    total = float(wb.sum())
    evidence: PopulationEvidence = {
        'block_s': float(block_s), 'blocks': len(blocks),
        'within_order': {ax: p.order for ax, p in zip(AXES, axes)}}
    if total != len(blocks):
        evidence['weighted_blocks'] = round(total, 4)
    if total < MIN_BLOCKS:
        evidence['fitted'] = False
        evidence['reason'] = (f'{total:g} blocks of {block_s:g} s with {MIN_BLOCK_SAMPLES} '
                              f'samples or more (recordings of one occasion counted once); '
                              f'a population needs {MIN_BLOCKS}')
        return PopulationFit(axes[0], axes[1], grand, None, evidence)
    model = ARErrorModel(axes[0], axes[1])
    rho = model.autocorrelation(ACF_LAGS)
    gamma0 = np.diag(model.stationary_cov)
    means = np.array([b.err.mean(axis=0) for b in blocks])
    n = np.array([len(b.err) for b in blocks])
    v = np.array([[mean_variance(rho[:, a], k, gamma0[a]) for a in range(2)] for k in n])
    dev = means - grand
    spread = (wb[:, None] * dev ** 2).sum(axis=0) / (total - 1)
    between = np.maximum(0.0, spread - np.average(v, axis=0, weights=wb))
    bias_sd = np.sqrt(between)
    c = np.array([[neighbour_covariance(rho[:, a], k, gamma0[a]) for a in range(2)] for k in n])
    pairs = neighbour_pairs(blocks)
    near = neighbour_cov_beyond(blocks, dev, c, pairs)
    tau, r = time_constant(len(pairs), near, between, block_s)
    r_estimate = neighbour_correlation(len(pairs), near, between)
    log_sd = np.array([np.mean(np.log(np.maximum(b.err.std(axis=0), 1e-6))) for b in blocks])
    rho2 = [1.0 + 2.0 * np.sum(rho[1:, a] ** 2) for a in range(2)]
    sampling = np.average([(rho2[0] + rho2[1]) / 2.0 / (4.0 * k) for k in n], weights=wb)
    log_var = float(np.sum(wb * (log_sd - np.average(log_sd, weights=wb)) ** 2) / (total - 1))
    scale_var = max(0.0, log_var - sampling)
    evidence['fitted'] = True
    evidence['block_mean_sd_m'] = [round(float(x), 4) for x in np.sqrt(spread)]
    evidence['within_mean_sd_m'] = [round(float(x), 4) for x in np.sqrt(v.mean(axis=0))]
    evidence['neighbour_pairs'] = len(pairs)
    evidence['neighbour_correlation'] = None if r is None else round(float(r), 4)
    evidence['neighbour_correlation_estimate'] = None if r_estimate is None else \
        round(float(r_estimate), 4)
    evidence['block_log_sd_sd'] = round(math.sqrt(log_var), 4)
    two = None if not two_scales or tau is None or r is None else \
        two_scale_bias(blocks, dev, v, near, r)
    pop = bias_section(blocks, bias_sd, tau, r, two, math.sqrt(scale_var), block_s, evidence,
                       r_estimate)
    return PopulationFit(axes[0], axes[1], grand, pop, evidence)


def block_pieces(segments: Sequence[Numbers], times: Sequence[Numbers], block_s: float = BLOCK_S,
                 alongside: Sequence[Sequence[Any]] = ()) -> list[tuple[Any, ...]]:
    """
    Return ``[(piece (k, 2), block number, *alongside)]``: each segment cut at its blocks' edges.

    Blocks are those of :func:`block_ids`; a piece is gap-free, so that
    neighbouring samples of one piece are neighbouring steps. Each array
    list in ``alongside`` (one array per segment, as the truth or the times)
    is cut the same way, its pieces following the error's.
    """
    pieces = []
    for seg, ids, *more in zip(segments, block_ids(times, block_s), *alongside):
        cuts = np.flatnonzero(np.diff(ids) != 0) + 1
        cut = [np.split(np.asarray(x), cuts) for x in (np.asarray(seg, dtype=float), *more)]
        pieces += [(p[0], int(i[0]), *p[1:]) for i, *p in zip(np.split(ids, cuts), *cut)]
    return pieces


def block_means(pieces: Sequence[tuple[Any, ...]]) -> dict[int, FloatArray]:
    """Return ``{block number: mean error (2,)}`` over :func:`block_pieces`' pieces."""
    by_block: dict[int, list[FloatArray]] = {}
    for s, i, *_ in pieces:
        by_block.setdefault(i, []).append(s)
    return {i: np.concatenate(v).mean(axis=0) for i, v in by_block.items()}


def _within_segments(segments: Sequence[Numbers], times: Sequence[Numbers],
                     block_s: float) -> tuple[list[FloatArray], list[int]]:
    """Return (the errors about their block's mean, in gap-free pieces; the blocks' sizes)."""
    pieces = block_pieces(segments, times, block_s)
    means = block_means(pieces)
    sizes: dict[int, int] = {}
    for s, i in pieces:
        sizes[i] = sizes.get(i, 0) + len(s)
    return [s - means[i] for s, i in pieces if len(s) > 1], [sizes[i] for i in means]


def population_line(fit: PopulationFit) -> str:
    """Return one line saying what a :class:`PopulationFit` found, or why it found nothing."""
    pop, ev = fit.population, fit.evidence
    if pop is None:
        return f'population: not fitted: {ev["reason"]}'
    counted = '' if 'weighted_blocks' not in ev else \
        f', {ev["weighted_blocks"]:.1f} with each occasion\'s recordings counted once'
    bias = _two_part_words(pop, ev) if 'held_sd_estimate_m' in ev else _one_part_words(pop, ev)
    return (f'population ({ev["blocks"]} blocks of {ev["block_s"]:g} s{counted}): a run\'s '
            f'bias has {bias}; an agent\'s scale has log SD {pop.scale_sd_log:.3f}; the AR '
            f'above is the process within a block')


#: The SD of the bias between days over that of the blocks within one (the horizontal RMS
#: of each): what a population from one occasion adds as a part held for the run, as an
#: allowance for days it did not see. From the SnapperGPS walks' five occasions (the fit of
#: all of them: held part 3.29 m against 2.82 m of wander; decision 0029).
DAY_RATIO = 1.17

#: What calibrate says of a population fitted from one occasion (the issue of another day).
ONE_OCCASION_NOTE = (
    'the population comes from one occasion (one recording, or recordings made together): '
    'its bias spread is how the 300-s blocks of that day differ, not how days differ, and '
    'another day\'s bias may fall outside it (on another day of one phone the mean error '
    'had the other sign). Recordings of several days give a spread between days')


def one_occasion_note(fit: PopulationFit) -> Optional[str]:
    """Return what calibrate says of a population from one occasion (None for several)."""
    if fit is None or fit.population is None or fit.evidence.get('occasions') != 1:
        return None
    days = fit.evidence.get('between_days')
    if not days:
        return ONE_OCCASION_NOTE + ' (no allowance added: --day-allowance 0)'
    return (ONE_OCCASION_NOTE + f'. An allowance for them is added as a part held for the '
            f'run, SD {days["held_sd_m"]:.2f} m per axis ({days["ratio"]:g} times the '
            f'blocks\' bias SD, from recordings of several days; --day-allowance 0 leaves '
            f'it out)')


def with_day_allowance(fit: PopulationFit, ratio: float = DAY_RATIO) -> PopulationFit:
    """
    Return ``fit`` with an allowance for other days, for a population of one occasion.

    A part held for the run of SD ``ratio`` times the horizontal RMS of the
    population's ``bias_sd_m``, the same on both axes (a day's bias is not
    tied to the axes of the blocks' spread), combined with any held part the
    fit found. Recorded in the evidence as ``between_days``. ``fit`` as it
    is without a population, with several occasions, or at ``ratio`` 0.
    """
    pop = fit.population
    if pop is None or fit.evidence.get('occasions') != 1 or ratio <= 0:
        return fit
    held = ratio * math.sqrt(0.5 * (pop.bias_sd_m[0] ** 2 + pop.bias_sd_m[1] ** 2))
    own = (0.0, 0.0) if pop.run_bias_sd_m is None else pop.run_bias_sd_m
    run = tuple(math.hypot(h, held) for h in own)
    evidence = fit.evidence.copy()
    evidence['between_days'] = {
        'ratio': float(ratio), 'held_sd_m': round(held, 4),
        'source': 'SD of the bias between days over that within a day, the SnapperGPS '
                  'walks (docs/decisions/0029-an-allowance-for-other-days.md)'}
    return replace(fit, population=replace(pop, run_bias_sd_m=run), evidence=evidence)


def _predicted(ev: PopulationEvidence, estimate: Sequence[float]) -> str:
    """Return what a new occasion's SD was predicted from, and the SD fitted."""
    return (f'(a new occasion\'s, predicted from {ev["independent_draws"]:.1f} independent '
            f'draws: the fitted SD is {estimate[0]:.2f} / {estimate[1]:.2f} m)')


def _one_part_words(pop: Population, ev: PopulationEvidence) -> str:
    """Return the words on a bias of one part (see :func:`population_line`)."""
    wander = 'constant for a run' if pop.bias_time_constant_s is None else \
        f'wandering with {time_constant_words(ev)}'
    shape = '' if pop.bias_dof is None else f', Student-t with {pop.bias_dof} degrees of freedom'
    seen = '' if ev.get('independent_draws') is None else \
        ' ' + _predicted(ev, ev['bias_sd_estimate_m'])
    days = '' if 'between_days' not in ev else \
        (f', and a part held for the run as an allowance for other days, SD '
         f'{ev["between_days"]["held_sd_m"]:.2f} m per axis')
    return (f'SD {pop.bias_sd_m[0]:.2f} m north, {pop.bias_sd_m[1]:.2f} m east{seen}{shape}, '
            f'{wander}{days}')


def _two_part_words(pop: Population, ev: PopulationEvidence) -> str:
    """Return the words on a bias held for the run and a wander (see :func:`population_line`)."""
    held = pop.run_bias_sd_m or (0.0, 0.0)
    shape = 'normal' if pop.bias_dof is None else \
        f'Student-t with {pop.bias_dof} degrees of freedom'
    return (f'a part held for the run, SD {held[0]:.2f} m north, {held[1]:.2f} m east '
            f'{_predicted(ev, ev["held_sd_estimate_m"])}, and a part that wanders with '
            f'{time_constant_words(ev)}, SD {pop.bias_sd_m[0]:.2f} / '
            f'{pop.bias_sd_m[1]:.2f} m (predicted from {ev["wander_contrasts"]:.1f} contrasts '
            f'of blocks within runs: the fitted SD is {ev["wander_sd_estimate_m"][0]:.2f} / '
            f'{ev["wander_sd_estimate_m"][1]:.2f} m); {shape}')

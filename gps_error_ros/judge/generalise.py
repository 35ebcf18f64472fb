"""
Does a profile hold on data its fit did not see? Several splits, grouped measures.

One 70/30 split judges a model on one held-out stretch. Here every class of
:mod:`.baselines`, and the population classes (:mod:`.population_class`),
is fitted and judged on several splits:

* **rolling origin** (:func:`rolling_splits`): for each origin in
  :data:`ORIGINS` (shares of the time span), train on everything before it
  and hold out the next :data:`HORIZON` of the span;
* **leave one recording out** (:func:`recording_splits`): train on every
  recording of a receiver but one and those made with it (its occasion:
  receivers carried together, :func:`~gps_error_ros.fit.population_fit.occasions`),
  hold that one out.

On each held-out part every class is scored by its one-step predictive log
density (the held-out NLL per sample: a proper score) and simulated along
the part's truth. The measured value of each measure is set against the
simulations' central 95 % range, and the measures come in groups, so that
no group outvotes another (:func:`grouped_measures`):

* ``persistence``: the ACF at lags 1 and 10 and the integral time scale
  (``1 + 2 sum`` of the ACF to lag 60), per axis;
* ``scale``: the SD per axis and the north-east correlation;
* ``bias``: the mean error per axis;
* ``quantiles``: the horizontal error's 50, 68, 95 and 99 % points;
* ``tails``: the share of steps whose horizontal change exceeds the
  training part's 99 % point, and the 99 % point of the held-out changes;
* ``filter`` and ``v2p``: what the consumers of :mod:`.consumers` conclude.

``inside_95`` of a group is the share of its measures inside their ranges.
"""

from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import replace
from typing import Any, TYPE_CHECKING

import numpy as np

from gps_error_ros.fit.fidelity import (acf_by_axis, part_fix_mask, run_masks,
                                        score_differences, simulate_part)
from gps_error_ros.diagnose.mean import condition_count
from gps_error_ros.fit.holdout import cut_trace, like_windows, Part, Split
from gps_error_ros.judge.velocity_check import has_velocity, velocity_group
from gps_error_ros.fit.envelope import (envelope, Envelope, inside, OUTAGE_MEASURES,
                                        outage_envelopes, outage_stats)
from gps_error_ros.fit.gross_failures import without_rows
from gps_error_ros.fit.population_fit import occasions, segment_weights
from gps_error_ros.judge.baselines import _classes, KEYS, training_outages
from gps_error_ros.judge.beaten import block_orders, pacf_against, part_pacf, where_beaten
from gps_error_ros.judge.consumers import consumer_measures, filter_parts
from gps_error_ros.judge.population_class import _within_split, PopulationClass
from gps_error_ros.judge.results import (ClassJudgement, Fold, group_of, measure_key,
                                         TrainingWindows)
from gps_error_ros.judge.window_persistence import persistence_spread
from gps_error_ros.model.state import BoolArray, FloatArray, Numbers
from gps_error_ros.traces.trace_io import join_recordings, Trace

if TYPE_CHECKING:
    from gps_error_ros.diagnose.pipeline import FittedModels
    from gps_error_ros.diagnose.models import FittedModel

#: Rolling origins, as shares of the time span.
ORIGINS = (0.5, 0.625, 0.75)
#: Each rolling fold's held-out share of the span.
HORIZON = 0.125
#: The groups of measures, in order.
GROUPS = ('persistence', 'scale', 'bias', 'quantiles', 'tails', 'filter', 'v2p')
#: The classes of this module, beside :data:`~.baselines.CLASSES`.
POPULATION = 'population'
POPULATION_AR = 'population_ar'
#: The class a population class is when its training part has too few blocks for a
#: ``population`` section (as ``calibrate --population`` then writes the whole part's fit).
WRAPS = {POPULATION: 'extended', POPULATION_AR: 'AR(p), PACF'}
ACF_LAGS = 60
#: Held-out samples the GTSAM smoother is run on (the first ones): it adds a pose per sample.
SMOOTHER_SAMPLES = 600
#: The classes that simulate outages: availability fitted on the training part's gaps.
OUTAGE_CLASSES = ('extended', 'population_ar', 'population')
#: Groups that only some folds or classes have, after :data:`GROUPS`.
EXTRA_GROUPS = ('outages', 'smoother')


def split_between(trace: Trace, cut_t: float, end_t: float, rule: str) -> Split:
    """
    Return the ``Split`` of ``trace``: train before ``cut_t``, test in [cut_t, end_t).

    (:class:`~gps_error_ros.fit.holdout.Split`.)

    Times are the trace's own (seconds); samples after ``end_t`` are in neither part.
    """
    train, test, truth, cut_s = cut_trace(trace, cut_t, end_t)
    velocity = None
    if has_velocity(trace):
        velocity = (without_rows(trace, trace.t >= cut_t),
                    without_rows(trace, (trace.t < cut_t) | (trace.t >= end_t)))
    return Split(train, test, truth, rule, cut_s, velocity=velocity)


def rolling_splits(trace: Trace, origins: Sequence[float] = ORIGINS,
                   horizon: float = HORIZON) -> list[tuple[str, Split]]:
    """Return [(label, Split)] of the rolling origins (see the module docstring)."""
    t0, t1 = float(trace.t[0]), float(trace.t[-1])
    span = t1 - t0
    out: list[tuple[str, Split]] = []
    for o in origins:
        end = t0 + (o + horizon) * span + (1e-6 if o + horizon >= 1.0 else 0.0)
        out.append((f'origin {o:.3g}', split_between(
            trace, t0 + o * span, end,
            f'train before {100 * o:.1f} % of the span, hold out the next '
            f'{100 * horizon:.1f} %')))
    return out


def recording_splits(traces: Sequence[Trace]) -> list[tuple[str, Split]]:
    """
    Return [(label, Split)]: each recording held out, those of other occasions train.

    A recording made together with the held-out one (the same walk or drive,
    another receiver) shares its bias, so it trains in no fold that holds
    the other out. The training segments carry their occasion weights.
    """
    out: list[tuple[str, Split]] = []
    labels = occasions(traces)
    for i, held in enumerate(traces):
        others = [t for j, t in enumerate(traces) if labels[j] != labels[i]]
        if not others:
            raise ValueError(f'every recording was made with {held.name} (one occasion): '
                             f'expected recordings of at least two occasions to leave one out')
        joined = join_recordings(others + [held])
        cut = float(joined.t[-len(held.t)])
        together = labels.count(labels[i]) - 1
        also = f' (nor the {together} recorded with it)' if together else ''
        split = split_between(joined, cut, float(joined.t[-1]) + 1.0,
                              f'train on {len(others)} recordings of other occasions, hold '
                              f'out {held.name}')
        weights = tuple(segment_weights(others, split.train.t))
        out.append((f'without {held.name}{also}', replace(split, train_weights=weights)))
    return out


# --- the measures ----------------------------------------------------------

def _basic(segments: Sequence[FloatArray], jump_m: float,
           recording: Sequence[Any] | None = None) -> dict[str, float]:
    """
    Return the error-statistic measures of one trace (list of segments), by name.

    ``recording``: each segment's recording; the autocorrelations and the
    integral time scale are taken within recordings and pooled.
    """
    x = np.concatenate(segments)
    acf = acf_by_axis(segments, ACF_LAGS, recording)
    out: dict[str, float] = {}
    for i, ax in enumerate(('north', 'east')):
        out[f'persistence:acf1_{ax}'] = float(acf[0, i])
        out[f'persistence:acf10_{ax}'] = float(acf[9, i])
        out[f'persistence:time_scale_{ax}_s'] = float(1.0 + 2.0 * acf[:, i].sum())
    out['scale:sd_north'], out['scale:sd_east'] = (float(v) for v in x.std(axis=0))
    out['scale:ne_correlation'] = float(np.corrcoef(x.T)[0, 1])
    out['bias:mean_north'], out['bias:mean_east'] = (float(v) for v in x.mean(axis=0))
    h = np.hypot(x[:, 0], x[:, 1])
    for p, v in zip((50, 68, 95, 99), np.quantile(h, [0.5, 0.68, 0.95, 0.99])):
        out[f'quantiles:q{p}_m'] = float(v)
    steps = np.concatenate([np.hypot(*np.diff(s, axis=0).T) for s in segments if len(s) > 1])
    out['tails:jump_rate'] = float(np.mean(steps > jump_m))
    out['tails:step_q99_m'] = float(np.quantile(steps, 0.99))
    return out


def _jump_threshold(train: Part) -> float:
    """Return the training part's 99 % point of the horizontal step between samples, m."""
    steps = np.concatenate([np.hypot(*np.diff(s, axis=0).T) for s in train.err if len(s) > 1])
    return float(np.quantile(steps, 0.99))


def grouped_measures(part: Part, train: Part, simulated: Sequence[Sequence[FloatArray]],
                     seed: int = 0, smoother_sims: int = 0,
                     outages: str | BoolArray | None = None
                     ) -> tuple[dict[str, Envelope], dict[str, float], dict[str, list[float]]]:
    """
    Return {measure: envelope row} and {group: inside_95} of ``part`` against ``simulated``.

    ``simulated``: traces, each a list of segments on ``part``'s samples.
    With ``outages`` (``'none'``: the class simulates a fix at every step,
    or its simulated fix masks over the part's span), the group ``outages``
    too: their number, the steps in them, the median and longest outage.
    With ``smoother_sims``, the group ``smoother`` too: GTSAM's iSAM2
    (:mod:`.smoother`) on the first :data:`SMOOTHER_SAMPLES` samples, fed
    the real fixes and those of the first ``smoother_sims`` simulated traces.

    Returns (rows, groups, own): ``own`` {group: each simulated trace's
    share inside} (:func:`own_shares`), over the groups every simulated
    trace has measures of (not the smoother's).
    """
    jump_m = _jump_threshold(train)
    measured = _basic(part.err, jump_m, part.recording)
    names = list(measured)
    sims = np.array([[m[n] for n in names]
                     for m in (_basic(s, jump_m, part.recording) for s in simulated)])
    cn, cm, cs = consumer_measures(part, part.err, simulated, train.err, seed)
    rows = {n: envelope(measured[n], sims[:, j]) for j, n in enumerate(names)}
    per_trace = {n: sims[:, j] for j, n in enumerate(names)}
    for j, n in enumerate(cn):
        key = measure_key(n.split('_')[0], n)
        rows[key] = envelope(cm[j], cs[:, j])
        per_trace[key] = cs[:, j]
    if smoother_sims:
        from gps_error_ros.judge.smoother import head, run_smoother, SMOOTHER_MEASURES
        short = head(part, SMOOTHER_SAMPLES)
        k = short.n
        fix_var = np.mean(np.concatenate(train.err) ** 2, axis=0)
        errors = np.stack([np.concatenate(part.err)[:k]] +
                          [np.concatenate(s)[:k] for s in simulated[:smoother_sims]])
        values = run_smoother(short, errors, fix_var, seed)
        for j, name in enumerate(SMOOTHER_MEASURES):
            rows[measure_key('smoother', name)] = envelope(values[0, j], values[1:, j])
    if outages is not None:
        mask = part_fix_mask(part)
        masks = np.ones((len(simulated), mask.size), dtype=bool) \
            if isinstance(outages, str) else outages
        for name, row in outage_envelopes(mask, masks).items():
            rows[measure_key('outages', name)] = row
        stats = np.array([outage_stats(m) for m in masks], dtype=float)
        for j, name in enumerate(OUTAGE_MEASURES):
            per_trace[measure_key('outages', name)] = stats[:, j]
    groups = {g: float(np.mean([inside(r) for k, r in rows.items() if group_of(k) == g]))
              for g in GROUPS + EXTRA_GROUPS if any(group_of(k) == g for k in rows)}
    return rows, groups, own_shares(per_trace)


def own_shares(values: Mapping[str, Numbers]) -> dict[str, list[float]]:
    """
    Return {group: each simulated trace's share of the group's measures inside (list)}.

    ``values`` {measure: the simulated traces' values (sims,)}: each trace
    is judged as the real one is, against the central 95 % of all the
    simulated traces (itself among them: one of 100 or more moves the
    range little). What a class's own traces score is what the real
    trace's shares are read against (:func:`~.fold_summary.own_verdict`).
    """
    names = list(values)
    v = np.column_stack([np.asarray(values[n], dtype=float) for n in names])
    lo, hi = np.percentile(v, [2.5, 97.5], axis=0)
    ins = (v >= lo) & (v <= hi)
    out: dict[str, list[float]] = {}
    for g in GROUPS + EXTRA_GROUPS:
        cols = [j for j, n in enumerate(names) if group_of(n) == g]
        if cols:
            out[g] = [round(float(x), 4) for x in ins[:, cols].mean(axis=1)]
    return out


def _outage_masks(split: Split, labels: Sequence[str], model: Any, sims: int,
                  seed: int) -> dict[str, str | BoolArray] | None:
    """
    Return {class label: its fix masks over the held-out span, or ``'none'``}, or None.

    None where neither part has an outage. The classes of
    :data:`OUTAGE_CLASSES` carry availability fitted on the training part's
    gaps (:func:`~.baselines.training_outages`; the masks depend on nothing
    but the availability and the keys, so ``model`` is any of the
    classes'); the others simulate a fix at every step.
    """
    masks = training_outages(split, model, sims, seed)
    if masks is None and not any(outage_stats(m)[0] for m in run_masks(split.test)):
        return None
    return {label: masks if masks is not None and KEYS.get(label, label) in OUTAGE_CLASSES
            else 'none' for label in labels}


def judge_split(fitted: 'FittedModels', sims: int = 100, seed: int = 0,
                within: 'FittedModel | None' = None, smoother_sims: int = 0,
                smoother_classes: Collection[str] | None = None) -> dict[str, ClassJudgement]:
    """
    Return {class key: {heldout_nll_per_sample, nll_minus_population, groups, measures}}.

    ``nll_minus_population``: the class's held-out NLL per sample minus the
    population class's (``population`` given ``within``, else
    ``population_ar``), paired on the same samples, with a 95 % interval
    (:func:`~gps_error_ros.fit.fidelity.score_differences`); the population class's
    ``where_beaten`` says in which held-out blocks the classes that score
    better than it beyond noise do so (:func:`~.beaten.where_beaten`; None
    for none).

    The reference class (``population``, else ``population_ar``) also has
    ``filter_parts`` (:func:`~.consumers.filter_parts`): what its filter's
    error is made of, measured against its simulated traces; and
    ``persistence_spread`` (:func:`~.window_persistence.persistence_spread`):
    how much the training part's lag-1 ACF moves from block to block,
    against traces it simulates on the training part's samples (None
    without a section or with too few blocks).

    ``smoother_sims``: traces of each class (of ``smoother_classes``, by
    default all) that the GTSAM smoother is fed as well (group ``smoother``).

    ``fitted``: the :class:`~gps_error_ros.diagnose.pipeline.FittedModels` of the split (its
    classes come from :func:`~.baselines._classes`); the population classes
    are fitted here on the same training part and scored on the same
    samples: ``population_ar`` (the Gaussian AR within blocks, as
    ``calibrate --population``) and, given ``within`` (the extended model
    fitted on :func:`within_part` of the training part), ``population``.
    """
    split = fitted.split
    m0 = condition_count(fitted.base.orders, fitted.extended.orders,
                         *(() if within is None else (within.orders,)))
    classes = _classes(fitted, sims, seed, m0)
    pops = {POPULATION_AR: PopulationClass(split.train, weights=split.train_weights)}
    if within is not None:
        pops[POPULATION] = PopulationClass(split.train, within, split.truth,
                                           split.train_weights)
    for label, pop in pops.items():
        if pop.fit.population is None:     # nothing to pool over: the class it wraps
            classes[label] = classes[WRAPS[label]]
            continue
        ll = pop.logpdf(split.test, m0)
        n = {len(v[0]) for v in classes.values()}
        if n != {len(ll)}:
            raise AssertionError(f'classes scored on different samples: {n} and {len(ll)}')
        classes[label] = (ll, simulate_part(pop, split.test, split.truth, sims, seed))
    outages = _outage_masks(split, list(classes), fitted.extended.simulator(), sims, seed)
    reference = POPULATION if within is not None else POPULATION_AR
    scores = {label: ll for label, (ll, _) in classes.items()}
    against = score_differences(scores, reference, seed)
    out: dict[str, ClassJudgement] = {}
    for label, (lls, traces) in classes.items():
        key = KEYS.get(label, label)
        smooth = smoother_sims if smoother_classes is None or key in smoother_classes else 0
        rows, groups, own = grouped_measures(split.test, split.train, traces, seed, smooth,
                                             None if outages is None else outages[label])
        out[key] = {'heldout_nll_per_sample': float(-np.mean(lls)),
                    'nll_minus_population': against[label],
                    'groups': groups, 'measures': rows, 'own_groups': own}
    for label, pop in pops.items():
        if pop.fit.population is None:
            out[label]['same_as'] = KEYS[WRAPS[label]]
        out[label]['fit'] = pop.fit.evidence
        out[label]['section'] = None if pop.fit.population is None else \
            pop.fit.population.to_dict()
    out[reference]['filter_parts'] = filter_parts(split.test, split.test.err,
                                                  classes[reference][1], split.train.err, seed)
    fit = pops[reference].fit
    out[reference]['persistence_spread'] = None if fit.population is None else \
        persistence_spread(split.train, simulate_part(pops[reference], split.train,
                                                      split.truth, sims, seed))
    if fit.population is not None:
        beaten = where_beaten(
            {KEYS.get(label, label): ll for label, ll in scores.items()},
            {KEYS.get(label, label): d for label, d in against.items()},
            KEYS.get(reference, reference), np.concatenate([e[m0:] for e in split.test.err]),
            np.concatenate([t[m0:] for t in split.test.t]), fit.mean,
            fit.population.bias_sd_total_m, seed)
        if beaten is not None:
            beaten['pacf'] = pacf_against(part_pacf(split.train), part_pacf(split.test))
            beaten['orders'] = {'train': block_orders(split.train),
                                'held_out': block_orders(split.test)}
        out[reference]['where_beaten'] = beaten
    return out


def judge_folds(splits: Sequence[tuple[str, Split]], sims: int = 100, seed: int = 0,
                done: Callable[[], object] | None = None, smoother_sims: int = 0,
                smoother_classes: Collection[str] | None = None) -> list[Fold]:
    """
    Fit and judge every class on every ``(label, Split)``; return the folds.

    Each fold: ``{'fold', 'rule', 'train_samples', 'test_samples',
    'train_measures', 'train_windows', 'classes', 'velocity'}``
    (:func:`judge_split`, with the smoother's arguments; the training part's
    own measures and :func:`training_windows` beside them; the speed and
    course group of the profile's velocity section, which every class
    shares, or None:
    :func:`~gps_error_ros.judge.velocity_check.velocity_group`). ``done()`` after each
    fold.
    """
    from gps_error_ros.diagnose.pipeline import fit_split
    folds: list[Fold] = []
    for label, split in splits:
        fitted = fit_split(label, split, seed=seed)
        within = fit_split(label, _within_split(split), seed=seed).extended
        folds.append({'fold': label, 'rule': split.rule, 'train_samples': split.train.n,
                      'test_samples': split.test.n,
                      'train_measures': _basic(split.train.err, float('inf'),
                                               split.train.recording),
                      'train_windows': training_windows(split.train, split.test),
                      'classes': judge_split(fitted, sims, seed, within, smoother_sims,
                                             smoother_classes),
                      'velocity': _velocity(split, sims, seed)})
        if done is not None:
            done()
    return folds


def _velocity(split: Split, sims: int, seed: int) -> dict[str, Any] | None:
    """Return the speed and course group of a split with velocity columns, or None."""
    if split.velocity is None:
        return None
    train, test = split.velocity
    return velocity_group(train, test, sims=sims, seed=seed)


def training_windows(train: Part, test: Part, gap_s: float = 60.0,
                     least: float = 0.8) -> TrainingWindows:
    """
    Return the range of each error measure over the training part's stretches like ``test``.

    Did what trained ever look like the held-out part? The training part is
    cut into runs (no gap over ``gap_s``: its recordings); every window of
    the held-out part's span within a run, stepped by half of it and holding
    at least ``least`` of the samples such a window can hold, and every run
    shorter than that span whole, is measured as the held-out part is
    (:func:`_basic`, the tails' threshold the training part's own). A
    held-out value outside a measure's range has no precedent in training.

    Returns ``{'span_s', 'windows', 'range': {measure: [low, high]}}``
    (``windows`` 0 and no ranges when no window qualifies).
    """
    t = np.concatenate(train.t)
    e = np.concatenate(train.err)
    seg = np.concatenate([np.full(len(x), i) for i, x in enumerate(train.err)])
    jump_m = _jump_threshold(train)
    test_t = np.concatenate(test.t)
    span = float(test_t[-1] - test_t[0])
    values = []
    for m in like_windows(t, span, gap_s, least):
        pieces = [e[m & (seg == i)] for i in np.unique(seg[m])]
        if any(len(p) > 1 for p in pieces):             # a step to measure
            values.append(_basic([p for p in pieces if len(p)], jump_m))
    if not values:
        return {'span_s': span, 'windows': 0, 'range': {}}
    return {'span_s': span, 'windows': len(values),
            'range': {k: [float(min(v[k] for v in values)), float(max(v[k] for v in values))]
                      for k in values[0]}}


def population_profile(split: Split, name: str, source: str, seed: int = 0) -> dict[str, Any]:
    """
    Return the population profile of a split's training part, as a profile mapping.

    The extended model fitted on the training errors about their blocks'
    means (:func:`within_part`), its mean the training part's, and the
    ``population`` section of :func:`~gps_error_ros.fit.population_fit.fit_population`
    (none when the training part has too few blocks): the class
    ``population`` of :func:`judge_split`.

    Parameters
    ----------
    split
        The diagnosis's split; its training part is fitted.
    name
        The profile's name.
    source
        What it was fitted to (the recording's name).
    seed
        The seed of the effect selection's simulations.

    Returns
    -------
    dict[str, Any]
        The profile (schema 1).

    """
    from gps_error_ros.diagnose.pipeline import fit_split
    from gps_error_ros.model.profiles import profile_mapping
    within = fit_split(name, _within_split(split), seed=seed).extended
    pop = PopulationClass(split.train, within, split.truth, split.train_weights)
    return profile_mapping(
        name, f'population profile diagnosed from {source}', f'gps_error diagnose {source}',
        pop.axes, effects=within.effects_obj(), population=pop.fit.population,
        fit={'method': 'the extended model fitted within blocks of 300 s of the training '
                       'part, and the blocks\' spread (gps_error_ros/fit/population_fit.py)',
             'input': source, 'train_samples': split.train.n,
             'effects_found': list(within.effects), 'population': pop.fit.evidence})

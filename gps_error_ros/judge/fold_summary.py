"""
Every class over the folds: the summary, the class's own traces, what had no precedent.

:func:`~.generalise.judge_folds` judges each class on each fold; this
module reads the folds together: :func:`summarise` (held-out NLL and each
group's share inside, averaged over the folds), :func:`own_verdict` (the
worst group read against the class's own simulated traces),
:func:`precedent` (held-out measures outside every training window like
them), and :func:`compare_on_folds`, which is ``gps_error compare --folds``.
"""

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from gps_error_ros.fit.holdout import Split
from gps_error_ros.judge.velocity_check import velocity_line
from gps_error_ros.fit.envelope import inside
from gps_error_ros.judge.beaten import beaten_lines
from gps_error_ros.judge.generalise import EXTRA_GROUPS, GROUPS, judge_folds, POPULATION
from gps_error_ros.judge.results import (ClassSummary, Fold, FoldComparison, group_of, name_of,
                                         OwnVerdict)
from gps_error_ros.judge.window_persistence import spread_line

#: Groups whose measures a training window can be measured on (the rest are the consumers').
ERROR_GROUPS = ('persistence', 'scale', 'bias', 'quantiles', 'tails')


def precedent(fold: Fold, cls: str = POPULATION) -> tuple[list[str], list[str]]:
    """
    Return (the error measures outside the class's range, those of them without precedent).

    A measure without precedent lies outside its range over the training
    part's own windows like the held-out part (``train_windows``, no window:
    none is a precedent): nothing that trained looked like it. Measures are
    named without their group.
    """
    windows = fold.get('train_windows')
    rng = {} if windows is None else windows['range']
    miss: list[str] = []
    new: list[str] = []
    for k, r in fold['classes'][cls]['measures'].items():
        if group_of(k) not in ERROR_GROUPS or inside(r):
            continue
        miss.append(name_of(k))
        lo, hi = rng.get(k, (np.inf, -np.inf))
        if not lo <= r['measured'] <= hi:
            new.append(name_of(k))
    return miss, new


def precedent_line(folds: Sequence[Fold], cls: str = POPULATION) -> str | None:
    """
    Return a line on the class's error measures outside their ranges, or None without any.

    How many, and per fold those that lie outside every training window
    like the held-out part as well (:func:`precedent`): a stationary profile
    fitted on the training part has nothing to carry over for them.
    """
    found = [(f['fold'], *precedent(f, cls)) for f in folds]
    miss = sum(len(m) for _, m, _ in found)
    if not miss:
        return None
    listed = '; '.join(f'{fold} {", ".join(new)}' for fold, _, new in found if new)
    return (f'  error measures outside their ranges ({cls}): {miss}, of which '
            f'{sum(len(n) for _, _, n in found)} outside every training window like the '
            f'held-out part as well (no precedent)' + (f': {listed}' if listed else ''))


def summarise(folds: Sequence[Fold]) -> dict[str, ClassSummary]:
    """
    Return per class: the held-out NLL per fold and its mean, the folds it scored best.

    A fold's best score is the lowest NLL of any class; classes that tie
    with it (a population class that is the class it wraps) each count it.
    ``nll_minus_population``: the class's NLL minus the population class's,
    mean over folds, and the folds on which its 95 % interval lies wholly
    below 0 (``lower_folds``: the class scores better beyond what the
    held-out samples leave open) or above 0 (``higher_folds``).

    And each group's ``inside_95`` averaged over the folds (those that have
    it, for the groups of :data:`EXTRA_GROUPS`), and the smallest
    of those (``worst_group``): a class holds where every group is near 0.95.
    Where the folds carry the class's own traces' shares, ``own``
    (:func:`own_verdict`): the worst group read against them.
    """
    classes = list(folds[0]['classes'])
    best = [min(f['classes'][c]['heldout_nll_per_sample'] for c in f['classes'])
            for f in folds]
    out: dict[str, ClassSummary] = {}
    for c in classes:
        nll = [f['classes'][c]['heldout_nll_per_sample'] for f in folds]
        groups = {g: float(np.mean(v)) for g in GROUPS + EXTRA_GROUPS
                  for v in [[f['classes'][c]['groups'][g] for f in folds
                             if g in f['classes'][c]['groups']]] if v}
        worst = min(groups, key=lambda g: groups[g])
        diff = [f['classes'][c]['nll_minus_population'] for f in folds]
        out[c] = {'heldout_nll_per_sample': float(np.mean(nll)),
                  'heldout_nll_per_fold': nll,
                  'best_score_folds': int(sum(n <= b + 1e-12 for n, b in zip(nll, best))),
                  'nll_minus_population': {
                      'mean': float(np.mean([d['mean'] for d in diff])),
                      'lower_folds': sum(d['ci95'][1] < 0.0 for d in diff),
                      'higher_folds': sum(d['ci95'][0] > 0.0 for d in diff)},
                  'groups': groups,
                  'worst_group': {'group': worst, 'inside_95': groups[worst]}}
        own = own_verdict([f['classes'][c] for f in folds])
        if own is not None:
            out[c]['own'] = own
    return out


#: The done-when's bar: every group's mean share inside at least this.
GROUP_BAR = 0.90


def own_verdict(fold_classes: Sequence[Mapping[str, Any]]) -> OwnVerdict | None:
    """
    Return the class's worst group read against its own traces', or None.

    ``fold_classes``: the class's entry of each fold, with ``groups`` and
    ``own_groups``. Over the groups every fold has own shares of, the
    simulated trace ``k`` of each fold together make one set of folds from
    the model (the folds' traces are independent draws): its groups' means
    over the folds, and their smallest. Returns ``{'groups', 'worst',
    'own_worst_median', 'percentile'`` (the share of own sets whose worst is
    at or below the real one's, %), ``'own_meet_bar'`` (the share of own
    sets with every group at :data:`GROUP_BAR` or more, %)``}``.
    """
    if not all('own_groups' in fc for fc in fold_classes):
        return None
    names = [g for g in GROUPS + EXTRA_GROUPS
             if all(g in fc['own_groups'] and g in fc['groups'] for fc in fold_classes)]
    sims = min(len(fc['own_groups'][g]) for fc in fold_classes for g in names)
    own = np.array([[np.mean([fc['own_groups'][g][k] for fc in fold_classes])
                     for g in names] for k in range(sims)])           # (sims, groups)
    real = np.array([np.mean([fc['groups'][g] for fc in fold_classes]) for g in names])
    worst, own_worst = float(real.min()), own.min(axis=1)
    return {'groups': names, 'worst': worst,
            'own_worst_median': float(np.median(own_worst)),
            'percentile': float(100.0 * np.mean(own_worst <= worst + 1e-12)),
            'own_meet_bar': float(100.0 * np.mean(np.all(own >= GROUP_BAR - 1e-12, axis=1)))}


def compare_on_folds(splits: Sequence[tuple[str, Split]], sims: int = 100, seed: int = 0,
                     done: Callable[[], object] | None = None,
                     smoother_sims: int = 0) -> FoldComparison:
    """
    Judge every class on every fold and over the folds: ``gps_error compare --folds``.

    :func:`judge_folds` and :func:`summarise`, with the lines that follow
    the table: each class's worst group against its own traces
    (:func:`own_verdict`), where a class beat the population class
    (:func:`~.beaten.beaten_lines`), and the measures without precedent,
    the persistence spread and the velocity group.
    """
    folds = judge_folds(splits, sims, seed, done=done, smoother_sims=smoother_sims)
    classes = summarise(folds)
    groups = GROUPS + tuple(g for g in EXTRA_GROUPS
                            if any(g in c['groups'] for c in classes.values()))
    notes: list[str] = []
    owns = {name: c['own'] for name, c in classes.items() if 'own' in c}
    if len(owns) == len(classes):
        notes.append('  worst group against the class\'s own traces (over the groups every '
                     'trace has; own: the median of its own; %: own sets of folds as low or '
                     f'lower; bar: own sets with every group >= {GROUP_BAR:.2f}):')
        notes += [f'  {name:13} {o["worst"]:5.2f}  own {o["own_worst_median"]:4.2f}  '
                  f'{o["percentile"]:5.1f} %  bar {o["own_meet_bar"]:5.1f} %'
                  for name, o in owns.items()]
    notes += beaten_lines(folds)
    notes += [line for line in (precedent_line(folds), spread_line(folds),
                                velocity_line(folds)) if line]
    return FoldComparison(folds, classes, sims, seed, groups, notes)

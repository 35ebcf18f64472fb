"""
Why can a model predict better and simulate worse? Experiments that tell.

Each function is one experiment of ``docs/close-the-loop.md`` on a fitted
diagnosis (:class:`~.pipeline.FittedModels`), the held-out part used only
to measure:

* :func:`block_statistics`: is the trace stationary? The training part's
  blocks and the held-out part side by side: error mean and SD per axis,
  the motion lag each alone would fit, the speed.
* :func:`reversed_split`: the same classes when the *first* 30 % is held
  out (trained on the rest): how much of a gap goes with the direction.
* :func:`effect_ablation`: where the effects enter: every subset of the
  effects found, held-out NLL against simulated fidelity, so the effect that
  costs fidelity is named.
* :func:`estimator_check`: the AR part by Yule-Walker (calibration's
  estimator) against conditional least squares (the diagnosis's), same
  orders.
* :func:`sampling_spread`: the simulated central 95 % range of the held-out
  SD and median error (sampling alone) against the change between the
  training and the held-out part.
"""

from typing import Any

import numpy as np

from gps_error_ros.diagnose.common import Orders, TRAIN_FRACTION
from gps_error_ros.fit.fidelity import (calibrated_fidelity, measure_vector,
                                        simulate_part)
from gps_error_ros.diagnose.mean import condition_count, design, MeanFit
from gps_error_ros.diagnose.models import fit_model, FittedModel, with_law
from gps_error_ros.diagnose.pipeline import fit_extended, FittedModels
from gps_error_ros.diagnose.selection import (FOLDS, shared_condition_count, subsets,
                                              time_blocks)
from gps_error_ros.fit.holdout import Part, Split, split_trace, TruthTrack
from gps_error_ros.fit.yule_walker import fit_axis
from gps_error_ros.traces.trace_io import Trace


def _part_row(label: str, part: Part, orders: Orders, truth: TruthTrack) -> dict[str, Any]:
    err = np.concatenate(part.err)
    speed = np.concatenate([np.hypot(*np.diff(t, axis=0).T) for t in part.truth
                            if len(t) > 1])
    lag = fit_model(part, orders, ('motion_lag',), truth).mean.lag_s
    return {'part': label, 'samples': part.n,
            'mean_m': [float(v) for v in err.mean(axis=0)],
            'sd_m': [float(v) for v in err.std(axis=0)],
            'motion_lag_s': float(lag),
            'median_speed_mps': float(np.median(speed)) if speed.size else 0.0}


def block_statistics(fitted: FittedModels, folds: int = FOLDS) -> list[dict[str, Any]]:
    """Return per training block and for the held-out part the row of statistics."""
    split, orders = fitted.split, fitted.base.orders
    rows = [_part_row(f'training block {i + 1}', b, orders, split.truth)
            for i, b in enumerate(time_blocks(split.train, folds))]
    rows.append(_part_row('held out', split.test, orders, split.truth))
    return rows


def reversed_split(trace: Trace) -> Split:
    """Return the :class:`Split` that holds out the first 30 % and trains on the rest."""
    s = split_trace(trace, 1.0 - TRAIN_FRACTION)
    return Split(s.test, s.train, s.truth,
                 f'last {100 * TRAIN_FRACTION:.0f} % of the time span trains, '
                 f'the first {100 * (1 - TRAIN_FRACTION):.0f} % is held out',
                 s.cut_time_s)


def _heldout(model: FittedModel, split: Split, m0: int, sims: int,
             seed: int) -> dict[str, Any]:
    ll = model.score(split.test, split.truth, m0)[0]
    traces = simulate_part(model, split.test, split.truth, sims, seed)
    cal = calibrated_fidelity(split.test, traces)
    q95 = cal['measures']['horizontal_q95']
    return {'heldout_nll_per_sample': float(-ll.mean()),
            'inside_95': cal['inside_95'],
            'failing': sorted(k for k, v in cal['measures'].items()
                              if not v['sim_lo'] <= v['measured'] <= v['sim_hi']),
            'q95_measured': q95['measured'], 'q95_sim_median': q95['sim_median']}


def effect_ablation(fitted: FittedModels, sims: int = 100,
                    seed: int = 0) -> list[dict[str, Any]]:
    """Return, for every subset of the effects found, the held-out measures."""
    split, base, att = fitted.split, fitted.base, fitted.attribution
    subs = subsets(tuple(att.effects))
    m0 = shared_condition_count(att.orders_for, subs)
    return [{'effects': list(sub),
             **_heldout(fit_extended(split, base, att, sub), split, m0, sims, seed)}
            for sub in subs]


def yule_walker_model(split: Split, orders: Orders) -> FittedModel:
    """Return the AR(p) with Yule-Walker coefficients, law fitted on its innovations."""
    phis, const = [], np.zeros(2)
    for a in range(2):
        p = fit_axis([e[:, a] for e in split.train.err], order=orders[a]).params
        phis.append(np.asarray(p.phi, dtype=float))
        const[a] = p.delta
    mean = MeanFit(const, phis)
    d = design(split.train, orders, split.truth)
    return with_law((), orders, mean, mean.residuals(d), d, 0)


def estimator_check(fitted: FittedModels, sims: int = 100,
                    seed: int = 0) -> dict[str, dict[str, Any]]:
    """Return the held-out measures of AR(p) by least squares and by Yule-Walker."""
    split, base = fitted.split, fitted.base
    m0 = condition_count(base.orders)
    return {'least squares': _heldout(base, split, m0, sims, seed),
            'Yule-Walker': _heldout(yule_walker_model(split, base.orders), split,
                                    m0, sims, seed)}


def sampling_spread(fitted: FittedModels, sims: int = 100,
                    seed: int = 0) -> dict[str, dict[str, float]]:
    """
    Return, per measure, training value, held-out value and simulated range.

    The base model simulates the held-out part's grid: its central 95 % range
    is what sampling alone moves a measure by on that many samples.
    """
    split, base = fitted.split, fitted.base
    traces = simulate_part(base, split.test, split.truth, sims, seed)
    sim = calibrated_fidelity(split.test, traces)['measures']
    train = measure_vector(split.train.err)
    names = ('sd_north', 'sd_east', 'horizontal_q50', 'horizontal_q95')
    return {n: {'training': train[n], 'held_out': sim[n]['measured'],
                'sim_lo': sim[n]['sim_lo'], 'sim_hi': sim[n]['sim_hi']}
            for n in names}

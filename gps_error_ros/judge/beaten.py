"""
Where a class scores better than the population class, and what tells the two apart.

When a class's held-out NLL lies below the population class's beyond its
95 % interval (:func:`~gps_error_ros.fit.fidelity.score_differences`), :func:`where_beaten`
says where: over held-out blocks far from the population's bias law or
near it (a gain only far out says the bias law is too narrow), and
:func:`part_pacf` / :func:`pacf_against` which lags of partial
autocorrelation the training part has and the held-out part lacks (dynamics
the population's process within carries over to data without them), and
:func:`block_orders` whether a part's lags hold across its own blocks (a
receiver's dynamics) or fit one stretch (a selection that over-fits).
"""

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from gps_error_ros.fit.fidelity import block_bootstrap_mean
from gps_error_ros.fit.holdout import Part
from gps_error_ros.fit.population_fit import (block_pieces, BLOCK_S, MIN_BLOCK_SAMPLES,
                                              MIN_BLOCKS)
from gps_error_ros.fit.yule_walker import CalibrationError, DEFAULT_MAX_ORDER, fit_axis
from gps_error_ros.model.state import BoolArray, FloatArray, Numbers

#: Scored held-out samples per block where :func:`where_beaten` shows a class's gain.
WHERE_BLOCK = 150
#: A block whose mean error lies beyond this many of the population's bias SDs from
#: the population's mean (on either axis) is one the population holds unlikely.
FAR_SD = 2.0
#: Nats per scored sample that more lags must gain in :func:`block_orders` to be chosen,
#: and be read as dynamics: a nat per hundred samples.
ORDER_GAIN = 0.01


def pacf_against(train: Mapping[str, Any] | None,
                 held_out: Mapping[str, Any] | None) -> dict[str, Any]:
    """
    Return ``{'train', 'held_out', 'only_in_training'}`` from two :func:`part_pacf`.

    ``only_in_training``: per axis, the lags whose partial autocorrelation
    lies beyond the bound in the training part and not in the held-out one
    (None where either part has none).
    """
    only = None
    if train is not None and held_out is not None:
        only = {axis: [k + 1 for k, (a, b) in enumerate(zip(train[axis], held_out[axis]))
                       if abs(a) > train['bound'] and abs(b) <= held_out['bound']]
                for axis in ('north', 'east')}
    return {'train': train, 'held_out': held_out, 'only_in_training': only}


def part_pacf(part: Part, lags: int = DEFAULT_MAX_ORDER) -> dict[str, Any] | None:
    """
    Return a part's partial autocorrelation at lags 1..``lags`` per axis and its bound, or None.

    ``{'north': [...], 'east': [...], 'bound': b}``: the pooled PACF of each
    axis's errors (gaps never bridged), and ``b = 1.96 / sqrt(n)``, beyond
    which a lag's partial autocorrelation is significant at 5 % (the
    bound ``calibrate`` chooses an AR order by). Fewer lags where the part
    has fewer than 4 samples a lag; None under 20 samples or where an
    axis's errors are constant.
    """
    n = sum(len(e) for e in part.err)
    lags = min(lags, n // 4 - 1)        # fit_axis needs 4 samples a lag
    if lags < 1 or n < 20:
        return None
    out: dict[str, Any] = {}
    for a, axis in enumerate(('north', 'east')):
        try:
            fit = fit_axis([e[:, a] for e in part.err], max_order=lags, axis=axis)
        except CalibrationError:        # an axis with constant errors has no PACF
            return None
        out[axis] = [float(v) for v in fit.pacf]
        out['bound'] = float(fit.pacf_bound)
    return out


def block_orders(part: Part, max_order: int = DEFAULT_MAX_ORDER,
                 block_s: float = BLOCK_S) -> dict[str, Any] | None:
    """
    Return the AR order per axis that predicts each block of ``part`` best from the others.

    The part is cut into the population fit's blocks of ``block_s``
    (:func:`~gps_error_ros.fit.population_fit.block_pieces`; gaps never
    bridged), each taken about its own mean (as the population's process
    within is fitted); blocks under :data:`MIN_BLOCK_SAMPLES` are left out.
    For each order ``p`` up to ``max_order`` and each block, an AR(p)
    fitted by least squares on the other blocks predicts the block's
    samples one step ahead (Gaussian, the fit's residual variance; every
    order scores the same samples, those ``max_order`` or more into a run
    of the block). The order is the smallest whose summed negative log
    density lies within :data:`ORDER_GAIN` per scored sample of the least
    (more lags must earn their keep). ``{'blocks': k, 'north': {'order',
    'gain_per_sample'}, 'east': ...}``, the gain being the chosen order's
    NLL below AR(1)'s per scored sample; None with fewer than
    :data:`MIN_BLOCKS` blocks.
    """
    blocks = _blocks(part, block_s, max_order)
    if len(blocks) < MIN_BLOCKS:
        return None
    out: dict[str, Any] = {'blocks': len(blocks)}
    for a, axis in enumerate(('north', 'east')):
        runs = [[r[:, a] for r in b] for b in blocks]
        nll = np.array([_left_out_nll(runs, p, max_order) for p in range(1, max_order + 1)])
        scored = sum(max(len(r) - max_order, 0) for b in runs for r in b)
        best = int(np.flatnonzero(nll <= nll.min() + ORDER_GAIN * scored)[0])
        out[axis] = {'order': best + 1, 'gain_per_sample': float((nll[0] - nll[best]) / scored)}
    return out


def _blocks(part: Part, block_s: float, max_order: int) -> list[list[FloatArray]]:
    """Return the blocks of ``part``: each a list of runs (n, 2) about the block's mean."""
    by_block: dict[int, list[FloatArray]] = {}
    for piece, i in block_pieces(part.err, part.t, block_s):
        by_block.setdefault(i, []).append(piece)
    out = []
    for runs in by_block.values():
        if sum(len(r) for r in runs) < MIN_BLOCK_SAMPLES:
            continue
        mean = np.concatenate(runs).mean(axis=0)
        out.append([r - mean for r in runs if len(r) > max_order])
    return [b for b in out if b]


def _lagged(runs: Sequence[FloatArray], p: int, first: int) -> tuple[FloatArray, FloatArray]:
    """Return (design (m, p), targets (m,)) of the runs' samples from index ``first`` on."""
    xs = [np.column_stack([r[first - i - 1:len(r) - i - 1] for i in range(p)]) for r in runs]
    return np.vstack(xs), np.concatenate([r[first:] for r in runs])


def _left_out_nll(runs: Sequence[Sequence[FloatArray]], p: int, max_order: int) -> float:
    """Return the summed one-step NLL of each block of ``runs``, an AR(p) fitted on the rest."""
    total = 0.0
    for k in range(len(runs)):
        rest = [r for j, b in enumerate(runs) if j != k for r in b]
        x, y = _lagged(rest, p, p)
        phi = np.linalg.lstsq(x, y, rcond=None)[0]
        var = max(float(np.mean((y - x @ phi) ** 2)), 1e-12)
        xo, yo = _lagged(runs[k], p, max_order)
        total += 0.5 * float(np.sum(np.log(2.0 * np.pi * var) + (yo - xo @ phi) ** 2 / var))
    return total


def where_beaten(lls: Mapping[str, Numbers], against: Mapping[str, Mapping[str, Any]],
                 reference: str, err: Numbers, t: Numbers, mean: Numbers, bias_sd: Numbers,
                 seed: int = 0, block: int = WHERE_BLOCK) -> dict[str, Any] | None:
    """
    Return where the classes that score better than ``reference`` beyond noise do so, or None.

    ``lls``: ``{class: per-sample log densities}`` on the scored held-out
    samples, whose errors (n, 2) and times are ``err`` and ``t``;
    ``against``: each class's NLL minus the reference's on them
    (:func:`~gps_error_ros.fit.fidelity.score_differences`); ``mean`` and ``bias_sd``: the
    population's mean error and bias SD per axis. The classes whose NLL
    lies below the reference's beyond its 95 % interval are the *winners*;
    with none, None. The scored samples are cut into consecutive blocks of ``block``
    (a last one under half a block joins the one before). Each block has its first time,
    its mean error, its *level* (the largest over the axes of the distance
    of its mean from ``mean``, in ``bias_sd``) and each winner's NLL minus
    the reference's over its samples. ``far``/``near``: over the blocks whose
    level exceeds :data:`FAR_SD` and the others, the samples and each
    winner's mean difference with its 95 % interval (the block bootstrap
    of the per-sample differences, blocks taken in time order).
    """
    winners = [c for c, d in against.items() if c != reference and d['ci95'][1] < 0.0]
    if not winners:
        return None
    ref = np.asarray(lls[reference], dtype=float)
    err, t = np.asarray(err, dtype=float), np.asarray(t, dtype=float)
    if err.shape != (ref.size, 2) or t.shape != (ref.size,):
        raise ValueError(f'{ref.size} scored samples, but errors of shape {err.shape} and '
                         f'times of shape {t.shape}; expected ({ref.size}, 2) and '
                         f'({ref.size},)')
    diffs = {c: ref - np.asarray(lls[c], dtype=float) for c in winners}
    cuts = list(range(0, ref.size, block))
    if len(cuts) > 1 and ref.size - cuts[-1] < block // 2:
        cuts.pop()
    edges = cuts + [ref.size]
    sd = np.maximum(np.asarray(bias_sd, dtype=float), 1e-9)
    rows: list[dict[str, Any]] = []
    far = np.zeros(ref.size, dtype=bool)
    for a, b in zip(edges[:-1], edges[1:]):
        m = err[a:b].mean(axis=0)
        level = float(np.max(np.abs(m - np.asarray(mean, dtype=float)) / sd))
        far[a:b] = level > FAR_SD
        rows.append({'t0_s': float(t[a]), 'samples': b - a, 'mean_m': [float(v) for v in m],
                     'level_sd': level,
                     'minus_reference': {c: float(d[a:b].mean()) for c, d in diffs.items()}})

    def gain(mask: BoolArray) -> dict[str, Any]:
        out: dict[str, Any] = {'samples': int(mask.sum())}
        for c, d in diffs.items():
            if mask.any():
                mu, lo, hi = block_bootstrap_mean(d[mask], seed=seed)
                out[c] = {'mean': mu, 'ci95': [lo, hi]}
        return out

    return {'block_samples': block, 'far_sd': FAR_SD, 'mean_m': [float(v) for v in mean],
            'bias_sd_m': [float(v) for v in bias_sd], 'winners': winners, 'blocks': rows,
            'far': gain(far), 'near': gain(~far)}


def gain_text(d: Mapping[str, Any]) -> str:
    """Return a difference ``{'mean', 'ci95'}`` as text: the mean and its interval."""
    return f'{d["mean"]:+.3f} ({d["ci95"][0]:+.3f} to {d["ci95"][1]:+.3f})'


def beaten_lines(folds: Sequence[Mapping[str, Any]]) -> list[str]:
    """Return lines on the folds where a class scores better than the population beyond noise."""
    out: list[str] = []
    for f in folds:
        wb = f['classes'].get('population', {}).get('where_beaten')
        if not wb:
            continue
        gains = {part: ', '.join(f'{c} {gain_text(wb[part][c])}' for c in wb['winners']
                                 if c in wb[part]) or '-' for part in ('far', 'near')}
        out.append(f'  {f["fold"]}: {", ".join(wb["winners"])} below the population class '
                   f'beyond the 95 % interval. NLL minus the population\'s over held-out '
                   f'blocks of {wb["block_samples"]} samples whose mean lies more than '
                   f'{wb["far_sd"]:g} bias SDs from the population\'s mean '
                   f'({wb["far"]["samples"]} samples): {gains["far"]}; over the others '
                   f'({wb["near"]["samples"]} samples): {gains["near"]}')
        only = (wb.get('pacf') or {}).get('only_in_training')
        if only is not None:
            out.append('    partial autocorrelation beyond 1.96/sqrt(n) in the training part '
                       'and not held out, lags: ' + '; '.join(
                           f'{axis} ' + (','.join(map(str, v)) or 'none')
                           for axis, v in only.items()))
        orders = wb.get('orders') or {}
        if orders.get('train'):
            out.append('    AR order that predicts each 300-s block best from the part\'s '
                       f'others: training part {_orders_text(orders["train"])}; held out '
                       f'{_orders_text(orders.get("held_out"))}')
    return out


def _orders_text(o: Mapping[str, Any] | None) -> str:
    """Return a part's :func:`~gps_error_ros.judge.beaten.block_orders` in words."""
    if o is None:
        return 'fewer than 3 blocks'
    return f'north {o["north"]["order"]}, east {o["east"]["order"]} ({o["blocks"]} blocks)'

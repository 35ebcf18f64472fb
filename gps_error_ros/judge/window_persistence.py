"""
Persistence from window to window: a part's lag-1 ACF from block to block, against a model's.

A population profile draws each agent's bias and scale, but every agent
shares one process and so one persistence. Whether that holds is told by
the training part itself: cut into the population fit's blocks
(:func:`~gps_error_ros.fit.population_fit.block_pieces`, each at least
:data:`~gps_error_ros.fit.population_fit.MIN_BLOCK_SAMPLES` samples), each
block has a lag-1 autocorrelation about its own mean. Their spread over the
blocks (SD) and their lowest value are set against the same figures of
traces the model simulates on the same samples: a spread above the model's
range says the recording's stretches differ in persistence more than the
model's own stretches do by chance, which no draw of bias or scale mends.
"""

from collections.abc import Sequence
from typing import Any

import numpy as np

from gps_error_ros.fit.holdout import Part
from gps_error_ros.fit.envelope import envelope, Envelope
from gps_error_ros.fit.population_fit import block_pieces, MIN_BLOCK_SAMPLES
from gps_error_ros.judge.results import Fold
from gps_error_ros.model.ar_model import AXES
from gps_error_ros.model.state import FloatArray, Numbers

#: Blocks the spread needs (an SD of fewer says nothing).
MIN_WINDOWS = 3


def window_acf1(segments: Sequence[FloatArray], times: Sequence[Numbers]) -> FloatArray:
    """
    Return each block's lag-1 autocorrelation per axis, (blocks, 2).

    ``segments``: error segments (n_s, 2); ``times``: their sample times, s.
    A block's mean is taken over all its samples; the lag-1 products are
    those of neighbouring samples of one segment (none across a gap).
    Blocks of fewer than :data:`MIN_BLOCK_SAMPLES` samples are left out.
    """
    by_block: dict[int, list[FloatArray]] = {}
    for piece, i in block_pieces(segments, times):
        by_block.setdefault(i, []).append(piece)
    out = []
    for pieces in by_block.values():
        x = np.concatenate(pieces)
        if len(x) < MIN_BLOCK_SAMPLES:
            continue
        mean = x.mean(axis=0)
        var = ((x - mean) ** 2).sum(axis=0)
        lag = sum(((p[1:] - mean) * (p[:-1] - mean)).sum(axis=0) for p in pieces)
        out.append(lag / np.maximum(var, 1e-300))
    return np.array(out).reshape(-1, 2)


def persistence_spread(part: Part,
                       simulated: Sequence[Sequence[FloatArray]]) -> dict[str, Any] | None:
    """
    Return the spread of ``part``'s block lag-1 ACFs against the simulated traces', or None.

    ``part``: a :class:`~gps_error_ros.fit.holdout.Part`; ``simulated``: traces, each a list of
    segments on ``part``'s samples. Per axis, :func:`~gps_error_ros.fit.envelope.envelope`
    rows of the blocks' ACF SD (``acf1_sd_<axis>``) and of their lowest ACF
    (``lowest_acf1_<axis>``), and ``windows``, the number of blocks; None
    with fewer than :data:`MIN_WINDOWS`.
    """
    measured = window_acf1(part.err, part.t)
    if len(measured) < MIN_WINDOWS:
        return None
    sims = [window_acf1(s, part.t) for s in simulated]
    out: dict[str, Any] = {'windows': len(measured)}
    for a, ax in enumerate(AXES):
        out[f'acf1_sd_{ax}'] = envelope(float(np.std(measured[:, a], ddof=1)),
                                        [np.std(s[:, a], ddof=1) for s in sims])
        out[f'lowest_acf1_{ax}'] = envelope(float(measured[:, a].min()),
                                            [s[:, a].min() for s in sims])
    return out


def spread_above(folds: Sequence[Fold], cls: str = 'population'
                 ) -> tuple[list[tuple[str, str, Envelope]], int]:
    """
    Return (the fold axes whose blocks' ACF spread lies above the class's range, those judged).

    The first: ``(fold, axis, envelope row)`` of each; the second, how many
    fold axes have the figures (``persistence_spread``) at all.
    """
    spreads = [(f['fold'], f['classes'][cls].get('persistence_spread'))
               for f in folds if cls in f['classes']]
    rows = [(fold, ax, spread[f'acf1_sd_{ax}']) for fold, spread in spreads if spread
            for ax in AXES]
    return [r for r in rows if r[2]['measured'] > r[2]['sim_hi']], len(rows)


def spread_line(folds: Sequence[Fold], cls: str = 'population') -> str | None:
    """
    Return a line on the folds' training blocks' ACF spread (``persistence_spread``), or None.

    None when no fold has the figures; else the folds and axes whose spread
    lies above the class's simulated 95 % range, with the range, or that
    none does.
    """
    above, judged = spread_above(folds, cls)
    if not judged:
        return None
    listed = '; '.join(f'{fold} {ax} {r["measured"]:.2f} ({r["sim_lo"]:.2f}-{r["sim_hi"]:.2f})'
                       for fold, ax, r in above)
    return (f'  persistence from block to block (SD of the training part\'s 300-s blocks\' '
            f'lag-1 ACF, against the population\'s own traces): above the range on '
            f'{len(above)} of {judged} fold axes' + (f': {listed}' if above else ''))

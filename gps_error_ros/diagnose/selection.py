"""
Step 5 of the diagnosis: which of the effects found the simulator keeps.

The tests of step 3 say which structures the training innovations hold;
they do not say that a model with all of them *simulates* the phone better.
An effect can lower the one-step likelihood while its simulated traces move
away from the data (a mean effect whose parameter drifts, a variance effect
that persists through the AR dynamics). So every subset of the effects
found is scored by blocked cross-validation over the training part, and the
held-out part is still used only to report.

Blocked cross-validation: the training part's time span is cut into
``FOLDS`` contiguous blocks; each block in turn is scored by a model fitted
on the other blocks (their segments kept apart, so no lag reaches across a
removed block). For AR models this is a valid estimate of the prediction
error (Bergmeir, Hyndman and Koo, Comput. Stat. Data Anal. 120, 2018).
Per block two measures: the one-step predictive NLL per sample, and how
well ``CV_SIMS`` traces simulated along the block's truth and grid cover the
block's measures (:func:`~.fidelity.calibrated_fidelity`). Motion lags are
re-estimated in every fold.

How well the simulations cover a measure is scored by its continuous ranked
probability score (CRPS, in the energy form E|X - y| - E|X - X'| / 2 over
the simulated values X and the measured y; Gneiting and Raftery, J. Am.
Stat. Assoc. 102, 2007). The score is proper: a simulator too wide pays in
spread what a too narrow one pays in distance, so it cannot win by
spreading its traces (``inside_95``, a share of measures covered, rewards
exactly that, and is still reported). Each measure's CRPS is divided by its
median spread E|X - X'| over the candidates in that block, so measures in
metres and autocorrelations weigh alike; the block's score is the mean over
the measures. It uses every simulated trace, not two order statistics: the
ratio of two runs of one model with other simulation seeds has a log SD of
about 0.07 per block, where the interval score of the 95 % ranges, tried
first, has about 0.3 and so vetoed at random.

The rule: the effects the tests found stand unless the blocks agree
against them. A subset is vetoed when another simulates better in every
block (its score lower by ``FIDELITY_TOLERANCE`` of it or more); a
subset replaces the effects found when it has the lower NLL in every block
and is not vetoed, the lowest mean NLL among such; if the effects found are
vetoed, the lowest mean NLL among the subsets not vetoed is kept.
"""

from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass, field
import itertools
from typing import Any

import numpy as np

from gps_error_ros.diagnose.common import DiagnosisError, EFFECT_ORDER, Orders
from gps_error_ros.fit.fidelity import (calibrated_fidelity, measure_draws,
                                        simulate_part)
from gps_error_ros.diagnose.mean import condition_count
from gps_error_ros.diagnose.models import fit_model
from gps_error_ros.fit.holdout import Part, Split
from gps_error_ros.model.state import FloatArray

#: Contiguous blocks of the training part.
FOLDS = 3
#: Simulated traces per block for its scores.
CV_SIMS = 50
#: Vetoed: another subset's score is lower by this share in every block. About
#: 1.5 Monte Carlo SDs of the ratio (log SD 0.07 with CV_SIMS traces): the
#: simulation noise alone gives such a ratio in all three blocks with a chance
#: of about 3e-4 for a pair of subsets that simulate alike.
FIDELITY_TOLERANCE = 0.10

RULE = (f'blocked cross-validation over the training part ({FOLDS} contiguous '
        f'blocks, each scored by a model fitted on the others): a subset is '
        f'vetoed when another has the CRPS of the measures of {CV_SIMS} '
        f'traces simulated per block (each measure scaled by its median '
        f'spread over the candidates) lower by '
        f'{100 * FIDELITY_TOLERANCE:.0f} % or more in every block; the '
        f'effects found stand unless a subset not vetoed has the lower one-step '
        f'NLL in every block (then the lowest mean NLL of those), or they are '
        f'vetoed (then the lowest mean NLL of the rest)')


def time_blocks(part: Part, k: int = FOLDS) -> list[Part]:
    """Return ``part`` cut into ``k`` contiguous blocks of equal time span."""
    t0, t1 = part.t[0][0], part.t[-1][-1]
    edges = t0 + (t1 - t0) * np.arange(k + 1) / k
    edges[-1] = np.inf
    blocks: list[Part] = []
    for b in range(k):
        block = Part([], [], [])
        for err, truth, t in zip(part.err, part.truth, part.t):
            idx = np.flatnonzero((t >= edges[b]) & (t < edges[b + 1]))
            if idx.size:
                block.err.append(err[idx])
                block.truth.append(truth[idx])
                block.t.append(t[idx])
        blocks.append(block)
    return blocks


def join_parts(parts: Iterable[Part]) -> Part:
    """Return one :class:`Part` holding the segments of ``parts``."""
    out = Part([], [], [])
    for p in parts:
        out.err += p.err
        out.truth += p.truth
        out.t += p.t
    return out


@dataclass
class Candidate:
    """One subset of the effects and its cross-validated measures."""

    effects: tuple[str, ...]
    nll: list[float] = field(default_factory=list)          # per block
    inside_95: list[float] = field(default_factory=list)    # per block
    # per block: (measured, simulated) measures
    draws: list[tuple[FloatArray, FloatArray]] = field(default_factory=list)
    fidelity_score: list[float] = field(default_factory=list)   # per block, set by choose
    failed: str = ''

    @property
    def mean_nll(self) -> float:
        """Return the mean NLL per sample over the blocks."""
        return float(np.mean(self.nll)) if self.nll else float('inf')

    @property
    def mean_inside_95(self) -> float:
        """Return the mean ``inside_95`` over the blocks."""
        return float(np.mean(self.inside_95)) if self.inside_95 else 0.0

    def to_dict(self) -> dict[str, Any]:
        """Return the candidate as plain data."""
        out: dict[str, Any] = {
            'effects': list(self.effects), 'cv_nll_per_sample': self.mean_nll,
            'cv_inside_95': self.mean_inside_95, 'nll_by_block': self.nll,
            'inside_95_by_block': self.inside_95, 'crps_by_block': self.fidelity_score}
        if self.failed:
            out['failed'] = self.failed
        return out


def cross_validate(split: Split, orders: Orders, effects: Collection[str], regimes: int,
                   seed: int = 0, folds: int = FOLDS, sims: int = CV_SIMS, period: int = 0,
                   m0: int | None = None) -> Candidate:
    """
    Return the :class:`Candidate` of ``effects`` scored over the blocks.

    ``m0``: samples per segment not scored (at least the orders' own count).
    """
    blocks = time_blocks(split.train, folds)
    m0 = condition_count(orders, (m0 or 0,))
    cand = Candidate(tuple(effects))
    for i, held in enumerate(blocks):
        rest = join_parts(b for j, b in enumerate(blocks) if j != i)
        try:
            # a fit that is not stationary cannot simulate (ModelError)
            model = fit_model(rest, orders, effects, split.truth, None, regimes, period)
            ll = model.score(held, split.truth, m0)[0]
            sims_i = simulate_part(model, held, split.truth, sims, seed + i)
        except (DiagnosisError, ValueError, np.linalg.LinAlgError) as exc:
            cand.failed = f'block {i}: {exc}'
            return cand
        if not ll.size or not np.all(np.isfinite(ll)):
            cand.failed = f'block {i}: no finite score'
            return cand
        cand.nll.append(float(-ll.mean()))
        draws = measure_draws(held, sims_i)
        cand.inside_95.append(calibrated_fidelity(held, sims_i, draws=draws)['inside_95'])
        cand.draws.append(draws[1:])
    return cand


@dataclass
class Selection:
    """The effects kept for the extended model, with every candidate's record."""

    kept: tuple[str, ...]
    candidates: list[Candidate]
    rule: str = RULE
    note: str = ''

    def to_dict(self) -> dict[str, Any]:
        """Return the selection as plain data."""
        out: dict[str, Any] = {'rule': self.rule, 'kept': list(self.kept),
                               'candidates': [c.to_dict() for c in self.candidates]}
        if self.note:
            out['note'] = self.note
        return out


def crps_scores(draws: Sequence[tuple[FloatArray, FloatArray]]) -> FloatArray:
    """
    Return the scaled CRPS of each candidate's simulated measures in one block.

    ``draws``: per candidate (measured (measures,), simulated (traces,
    measures)), the measured values the same for all. The CRPS of a measure
    is E|X - y| - E|X - X'| / 2 over the simulated values X (the energy
    form); each is divided by that measure's median spread E|X - X'| over
    the candidates, and the block's score is the mean over the measures.
    Measures that no candidate spreads (a statistic every simulation gives
    alike) are left out.
    """
    y = np.asarray(draws[0][0], dtype=float)
    crps: list[FloatArray] = []
    spread: list[FloatArray] = []
    for _, x in draws:
        x = np.sort(np.asarray(x, dtype=float), axis=0)
        s = len(x)
        # E|X - X'| from the order statistics: 2 / s^2 sum (2i - s - 1) x_(i)
        gini = 2.0 / s ** 2 * ((2 * np.arange(1, s + 1) - s - 1) @ x)
        crps.append(np.abs(x - y).mean(axis=0) - gini / 2.0)
        spread.append(gini)
    scale = np.median(spread, axis=0)
    use = scale > 0
    if not use.any():
        return np.zeros(len(draws))
    return (np.array(crps)[:, use] / scale[use]).mean(axis=1)


def score_candidates(ok: Sequence[Candidate]) -> None:
    """Set every candidate's :func:`crps_scores` per block, scaled in common."""
    for c in ok:
        c.fidelity_score = []
    for b in range(min(len(c.draws) for c in ok)):
        for c, v in zip(ok, crps_scores([c.draws[b] for c in ok])):
            c.fidelity_score.append(float(v))


def _vetoed(c: Candidate, ok: Sequence[Candidate], tolerance: float) -> bool:
    """Return whether another candidate simulates better than ``c`` in every block."""
    return any(other.fidelity_score and
               all(o <= v * (1.0 - tolerance) for o, v in
                   zip(other.fidelity_score, c.fidelity_score))
               for other in ok if other is not c)


def _beats(c: Candidate, ref: Candidate) -> bool:
    """Return whether ``c`` has the lower NLL than ``ref`` in every block."""
    return all(a < b for a, b in zip(c.nll, ref.nll))


def choose(candidates: Sequence[Candidate], found: Collection[str] | None = None,
           tolerance: float = FIDELITY_TOLERANCE) -> Candidate:
    """
    Return the kept :class:`Candidate` by the module's rule.

    ``found``: the effects the tests attributed (default: the largest
    candidate), the choice that stands unless the blocks agree against it.
    Sets every candidate's ``fidelity_score``: each measure is scaled by a
    spread common to the candidates scored together, so the scores compare
    within one call only.
    """
    ok = [c for c in candidates if not c.failed]
    if not ok:
        raise DiagnosisError('no subset of the effects could be cross-validated')
    score_candidates(ok)
    ref = max(ok, key=lambda c: len(c.effects)) if found is None else \
        next((c for c in ok if set(c.effects) == set(found)), None)
    allowed = [c for c in ok if not _vetoed(c, ok, tolerance)]
    if ref is not None and ref in allowed:
        allowed = [ref] + [c for c in allowed if _beats(c, ref)]
    return min(allowed, key=lambda c: (round(c.mean_nll, 9), len(c.effects)))


def subsets(effects: Sequence[str]) -> list[tuple[str, ...]]:
    """Return every subset of ``effects`` (tuples, in order), the empty one first."""
    return [sub for k in range(len(effects) + 1)
            for sub in itertools.combinations(effects, k)]


def shared_condition_count(orders_for: Callable[[tuple[str, ...]], Orders],
                           subs: Iterable[tuple[str, ...]]) -> int:
    """Return the samples per segment left unscored so that every subset scores the same."""
    return condition_count(*(orders_for(sub) for sub in subs))


def select_effects(split: Split, orders_for: Callable[[tuple[str, ...]], Orders],
                   effects: Collection[str], regimes: int, seed: int = 0, period: int = 0
                   ) -> Selection:
    """
    Return the :class:`Selection` among all subsets of ``effects``.

    ``orders_for``: a function of a subset that gives its AR orders; every
    subset is scored on the same samples.

    Without effects there is nothing to choose: the base model, no record.
    When no subset can be cross-validated (every fold's fit fails, e.g. not
    stationary on a short block), all effects found are kept and ``note``
    says why.
    """
    effects = tuple(e for e in EFFECT_ORDER if e in effects)
    if not effects:
        return Selection((), [])
    subs = subsets(effects)
    m0 = shared_condition_count(orders_for, subs)
    cands = [cross_validate(split, orders_for(sub), sub, regimes, seed, period=period, m0=m0)
             for sub in subs]
    try:
        return Selection(choose(cands, effects).effects, cands)
    except DiagnosisError as exc:
        return Selection(effects, cands, note=f'{exc} (first: {cands[0].failed}); '
                                              f'all effects found are kept')

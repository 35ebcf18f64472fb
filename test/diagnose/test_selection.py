"""Step 5 of the diagnosis: which effects found the simulator keeps."""

import itertools
import math

import numpy as np
import pytest

from gps_error_ros.diagnose import DiagnosisError
from gps_error_ros.diagnose.pipeline import fit_models
from gps_error_ros.diagnose.selection import (Candidate, choose, FOLDS,
                                              FIDELITY_TOLERANCE, crps_scores,
                                              join_parts, time_blocks)
from gps_error_ros.sim.synthetic import synthetic_trace


@pytest.fixture(scope='module')
def fitted():
    """Return steps 1-5 on a walk with variance regimes (two effects can be found)."""
    return fit_models(synthetic_trace('canyon_levels', 0, 2400))


def test_blocks_cut_the_training_part_in_time_and_lose_nothing(fitted):
    train = fitted.split.train
    blocks = time_blocks(train, FOLDS)
    assert len(blocks) == FOLDS
    assert sum(b.n for b in blocks) == train.n
    # contiguous and in order: every block ends before the next begins
    for a, b in zip(blocks, blocks[1:]):
        assert a.t[-1][-1] < b.t[0][0]
    span = train.t[-1][-1] - train.t[0][0]
    for b in blocks:
        assert b.t[-1][-1] - b.t[0][0] <= span / FOLDS + 1.0
    joined = join_parts(blocks)
    assert np.array_equal(np.concatenate(joined.err), np.concatenate(train.err))
    # a block boundary starts a new segment: no lag reaches across it
    assert len(joined.err) >= len(train.err)
    assert all(np.all(np.diff(t) > 0) for t in joined.t)


def _cand(effects, nll, ranges, failed=''):
    """Return a candidate whose one measure is 0, simulated evenly over ``ranges`` per block."""
    draws = [(np.zeros(1), np.linspace(lo, hi, 41)[:, None]) for lo, hi in ranges]
    return Candidate(effects, nll, [float(lo <= 0.0 <= hi) for lo, hi in ranges], draws,
                     failed=failed)


def test_the_crps_is_the_energy_form_and_does_not_depend_on_units():
    rng = np.random.default_rng(3)
    y = np.array([0.3, 0.01])
    draws = [(y, rng.normal(0.0, [1.0, 0.02], (50, 2))),
             (y, rng.normal(0.5, [2.0, 0.01], (50, 2)))]

    def brute(x, v):
        return np.abs(x - v).mean() - np.abs(x[:, None] - x[None, :]).mean() / 2

    crps = np.array([[brute(x[:, j], y[j]) for j in range(2)] for _, x in draws])
    spread = np.array([[np.abs(x[:, j, None] - x[None, :, j]).mean() for j in range(2)]
                       for _, x in draws])
    want = (crps / np.median(spread, axis=0)).mean(axis=1)
    assert np.allclose(crps_scores(draws), want)
    # metres -> centimetres for the first measure: the same scores
    cm = np.array([100.0, 1.0])
    assert np.allclose(crps_scores([(y * cm, x * cm) for _, x in draws]), want)
    # a statistic every candidate simulates alike carries no information
    assert np.allclose(crps_scores([(np.ones(1), np.zeros((5, 1)))] * 2), 0.0)


def test_the_crps_prefers_the_simulator_that_made_the_data_to_a_wider_or_narrower_one():
    rng = np.random.default_rng(4)
    y = rng.normal(0.0, 1.0, 400)                 # 400 measures, each a N(0, 1) value
    draws = [(y, rng.normal(0.0, sd, (200, y.size))) for sd in (0.4, 1.0, 2.5)]
    narrow, right, wide = crps_scores(draws)
    assert right < narrow and right < wide
    # the share inside the central 95 % would prefer the wide one
    inside = [np.mean((np.percentile(x, 2.5, axis=0) <= y) & (y <= np.percentile(x, 97.5, axis=0)))
              for _, x in draws]
    assert inside[2] > inside[1]


def test_the_effects_found_stand_unless_every_block_agrees_against_them():
    found = ('heavy_tails', 'variance_regimes')
    cover = [(-1.0, 1.0)] * 3
    full = _cand(found, [1.0, 1.0, 1.0], cover)
    # lower NLL on average but not in every block: the effects found stand
    mixed = _cand(('variance_regimes',), [0.5, 1.1, 0.5], cover)
    assert choose([full, mixed], found) is full
    # lower NLL in every block and not vetoed: it replaces them
    better = _cand(('heavy_tails',), [0.9, 0.95, 0.9], [(-1.0, 1.1)] * 3)
    assert choose([full, mixed, better], found) is better
    # better NLL everywhere but its ranges miss the measured value in every block: vetoed
    wild = _cand(('heavy_tails',), [0.5, 0.5, 0.5], [(0.5, 1.5)] * 3)
    assert choose([full, wild], found) is full
    assert all(f <= w * (1 - FIDELITY_TOLERANCE) for w, f in
               zip(wild.fidelity_score, full.fidelity_score))
    # the effects found vetoed: the lowest mean NLL of the rest
    miss = _cand(found, [1.0, 1.0, 1.0], [(0.2, 2.2)] * 3)
    plain = _cand((), [1.2, 1.2, 1.2], cover)
    calm = _cand(('variance_regimes',), [0.5, 1.1, 0.5], [(-1.1, 1.0)] * 3)
    assert choose([miss, calm, plain], found) is calm
    # equal NLL: the fewer effects
    a = _cand(('heavy_tails',), [0.8, 0.8], cover[:2])
    b = _cand((), [0.8, 0.8], cover[:2])
    assert choose([a, b], ('heavy_tails',)) is a      # found stands: b not lower everywhere
    assert choose([a, b]) is a
    failed = _cand(('motion_lag',), [0.1], [(-1.0, 1.0)], failed='block 1: singular')
    assert choose([full, failed], found) is full
    with pytest.raises(DiagnosisError, match='no subset'):
        choose([failed])


def test_a_simulator_too_wide_does_not_veto_one_that_misses_narrowly():
    # the share covered would prefer the wide one (1.0 against 0.0 in every block)
    found = ('periodic', 'outliers')
    narrow = _cand(found, [3.4, 3.4, 3.4], [(0.02, 1.02)] * 3)
    wide = _cand(('outliers',), [3.8, 3.8, 3.8], [(-6.0, 6.0)] * 3)
    assert all(w > n for w, n in zip(wide.inside_95, narrow.inside_95))
    assert choose([narrow, wide], found) is narrow
    assert all(n < w for n, w in zip(narrow.fidelity_score, wide.fidelity_score))
    # but one that misses by more than it would gain in width is vetoed
    far = _cand(found, [3.4, 3.4, 3.4], [(1.0, 2.0)] * 3)
    assert choose([far, wide], found) is wide


def test_every_subset_is_cross_validated_and_the_extended_model_has_the_kept_one(fitted):
    found = tuple(fitted.attribution.effects)
    assert 'variance_regimes' in found
    sel = fitted.selection
    want = {sub for k in range(len(found) + 1)
            for sub in itertools.combinations(found, k)}
    assert {c.effects for c in sel.candidates} == want
    for c in sel.candidates:
        assert not c.failed
        assert len(c.nll) == len(c.inside_95) == FOLDS
        assert all(math.isfinite(v) for v in c.nll)
        assert all(0.0 <= v <= 1.0 for v in c.inside_95)
        assert len(c.fidelity_score) == FOLDS
        assert all(math.isfinite(v) and v > 0 for v in c.fidelity_score)
    assert set(sel.kept) <= set(found)
    assert fitted.extended.effects == sel.kept
    assert choose(sel.candidates, found).effects == sel.kept
    # regimes made these data: the cross-validation keeps them
    assert 'variance_regimes' in sel.kept
    doc = sel.to_dict()
    assert doc['kept'] == list(sel.kept) and len(doc['candidates']) == len(want)

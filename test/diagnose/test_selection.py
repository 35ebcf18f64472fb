"""Step 5 of the diagnosis: which effects found the simulator keeps."""

import itertools
import math

import numpy as np
import pytest

from gps_error_ros.diagnose import DiagnosisError
from gps_error_ros.diagnose.pipeline import fit_models
from gps_error_ros.diagnose.selection import (Candidate, choose, FOLDS,
                                              FIDELITY_TOLERANCE, join_parts,
                                              time_blocks)
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


def test_the_effects_found_stand_unless_every_block_agrees_against_them():
    found = ('heavy_tails', 'variance_regimes')
    full = Candidate(found, [1.0, 1.0, 1.0], [0.90, 0.80, 0.90])
    # lower NLL on average but not in every block: the effects found stand
    mixed = Candidate(('variance_regimes',), [0.5, 1.1, 0.5], [0.90, 0.80, 0.90])
    assert choose([full, mixed], found) is full
    # lower NLL in every block and not vetoed: it replaces them
    better = Candidate(('heavy_tails',), [0.9, 0.95, 0.9], [0.88, 0.80, 0.92])
    assert choose([full, mixed, better], found) is better
    # better NLL everywhere but simulating worse in every block: vetoed
    wild = Candidate(('heavy_tails',), [0.5, 0.5, 0.5], [0.80, 0.70, 0.80])
    assert all(a - b >= FIDELITY_TOLERANCE for a, b in zip(full.inside_95, wild.inside_95))
    assert choose([full, wild], found) is full
    # the effects found vetoed: the lowest mean NLL of the rest
    plain = Candidate((), [1.2, 1.2, 1.2], [0.99, 0.99, 0.99])
    calm = Candidate(('variance_regimes',), [0.5, 1.1, 0.5], [0.96, 0.96, 0.96])
    assert choose([full, calm, plain], found) is calm
    # equal NLL: the fewer effects
    a = Candidate(('heavy_tails',), [0.8, 0.8], [0.9, 0.9])
    b = Candidate((), [0.8, 0.8], [0.9, 0.9])
    assert choose([a, b], ('heavy_tails',)) is a      # found stands: b not lower everywhere
    assert choose([a, b]) is a
    failed = Candidate(('motion_lag',), [0.1], [1.0], failed='block 1: singular')
    assert choose([full, failed], found) is full
    with pytest.raises(DiagnosisError, match='no subset'):
        choose([failed])


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
    assert set(sel.kept) <= set(found)
    assert fitted.extended.effects == sel.kept
    assert choose(sel.candidates, found).effects == sel.kept
    # regimes made these data: the cross-validation keeps them
    assert 'variance_regimes' in sel.kept
    doc = sel.to_dict()
    assert doc['kept'] == list(sel.kept) and len(doc['candidates']) == len(want)

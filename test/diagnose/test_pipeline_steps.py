"""Each step of ``diagnose`` on its own (the pipeline is their list)."""

from dataclasses import replace

import numpy as np
import pytest

from gps_error_ros.diagnose import DiagnosisError
from gps_error_ros.diagnose.common import FAMILY_ALPHA, MIN_TEST, N_TESTS, TRAIN_FRACTION
from gps_error_ros.diagnose.family import holm
from gps_error_ros.diagnose.mean import condition_count
from gps_error_ros.diagnose.models import select_orders
from gps_error_ros.diagnose.pipeline import (_motion_family, attribute, fit_base, fit_extended,
                                             heldout_measures, retest_extended,
                                             split_step, run_family, FamilyResult)
from gps_error_ros.fit.calibration import errors_on_grid
from gps_error_ros.fit.yule_walker import fit_axis
from gps_error_ros.sim.synthetic import synthetic_trace

FAMILY = {'motion_dependence', 'cross_axis_correlation', 'kurtosis',
          'squared_persistence', 'squared_oscillation', 'serial_north',
          'serial_east', 'travel_frame', 'periodicity', 'jump_reversal'}


@pytest.fixture(scope='module')
def coupled():
    """Return a walk whose innovations are elongated along the avenues, split and fitted."""
    trace = synthetic_trace('street_ellipse', 1, 3600)
    split = split_step(trace)
    base = fit_base(split)
    return trace, split, base, run_family(split, base)


def test_split_cuts_the_grid_in_time(coupled):
    trace, split, _, _ = coupled
    assert split.train.n + split.test.n == errors_on_grid(trace).n
    last_train = max(t[-1] for t in split.train.t)
    first_test = min(t[0] for t in split.test.t)
    t0 = trace.t[0]
    assert last_train < t0 + split.cut_time_s <= first_test
    span = trace.t[-1] - t0
    assert split.cut_time_s == pytest.approx(TRAIN_FRACTION * span, abs=1.5)
    with pytest.raises(DiagnosisError, match='need at least'):
        split_step(synthetic_trace('none', 0, 200))


def test_base_model_takes_calibrations_pacf_orders(coupled):
    _, split, base, _ = coupled
    want = tuple(fit_axis([e[:, a] for e in split.train.err]).params.order
                 for a in range(2))
    assert base.orders == want == select_orders(split.train)
    assert base.effects == () and base.law.cov[0, 1] == 0.0
    m0 = condition_count(base.orders)
    assert base.n_train == sum(max(0, len(e) - m0) for e in split.train.err)


def test_family_is_holm_over_nine_tests(coupled):
    _, _, _, family = coupled
    assert set(family.tests) == FAMILY
    reject, adjusted = holm({k: t.p_value for k, t in family.tests.items()}, FAMILY_ALPHA)
    for k, t in family.tests.items():
        assert t.holm_adjusted_p == adjusted[k]
        assert t.rejected == reject[k] == (adjusted[k] <= FAMILY_ALPHA)
    assert family.tests['cross_axis_correlation'].rejected
    assert family.tests['cross_axis_correlation'].statistic > 0.1


def test_attribution_follows_the_rejections(coupled):
    _, split, base, family = coupled
    att = attribute(split, base, family)
    assert att.effects == ['cross_axis_coupling'], family.reject
    assert att.evidence['cross_axis_coupling']['test'] == 'cross_axis_correlation'
    # the same data with tails claimed and no persistence: heavy_tails wins and
    # the regimes are listed as rejected; periodic variance stays unexplained
    reject = {k: False for k in FAMILY} | {'kurtosis': True,
                                           'squared_oscillation': True}
    tests = dict(family.tests)
    fake = FamilyResult(tests, reject, {k: 0.5 for k in FAMILY})
    att = attribute(split, base, fake)
    assert att.effects == ['heavy_tails']
    assert [a.effect for a in att.alternatives_rejected] == ['variance_regimes']
    assert set(att.evidence['heavy_tails']['bic']) >= {'neither', 'heavy_tails'}
    assert [u.stage for u in att.unexplained] == ['base model']
    assert 'periodic variance' in att.unexplained[0].structure
    # a cycle found: periodic, at the divisor of the test's period with the
    # lowest training BIC; the squared innovations' oscillation is then its
    tests['periodicity'] = replace(tests['periodicity'], p_value=1e-3, statistic=9.0,
                                   about={'at_period': 12, 'in': 'mean'})
    reject['periodicity'] = True
    att = attribute(split, base, FamilyResult(tests, reject, {k: 0.5 for k in FAMILY}))
    assert att.effects == ['heavy_tails', 'periodic'] and att.unexplained == []
    bics = att.evidence['periodic']['bic_by_period']
    assert set(bics) == {'2', '3', '4', '6', '12'}
    assert att.period == int(min(bics, key=bics.get))


def test_extended_fit_and_retest(coupled):
    _, split, base, family = coupled
    att = attribute(split, base, family)
    ext = fit_extended(split, base, att)
    assert ext.effects == ('cross_axis_coupling',) and ext.orders == base.orders
    assert ext.effects_obj().innovation_corr > 0.1
    assert ext.train_loglik > base.train_loglik
    retests, (r, seg, pred) = retest_extended(split, ext, att)
    assert not retests['cross_axis_correlation'].rejected
    assert retests['cross_axis_correlation'].explained_by == ('cross_axis_coupling',)
    assert len(r) == len(seg) == len(pred) == ext.n_train
    quiet = FamilyResult(family.tests, {k: False for k in FAMILY},
                         {k: 1.0 for k in FAMILY})
    none = attribute(split, base, quiet)
    assert fit_extended(split, base, none) is base
    assert retest_extended(split, base, none)[0] == {}


def test_heldout_measures_score_the_same_samples(coupled):
    trace, split, base, family = coupled
    ext = fit_extended(split, base, attribute(split, base, family))
    before, after, imp, scored = heldout_measures(split, base, ext, 10, 0, trace.name)
    assert scored >= MIN_TEST // 2
    assert imp.heldout_nll_per_sample == pytest.approx(
        before.heldout_nll_per_sample - after.heldout_nll_per_sample, abs=1e-12)
    lo, hi = imp.ci95
    assert lo <= imp.heldout_nll_per_sample <= hi
    assert after.heldout_nll_per_sample < before.heldout_nll_per_sample
    assert before.fidelity['sims'] == after.fidelity['sims'] == 10
    assert np.isfinite(after.fidelity['acf_distance'])


def test_with_jumps_the_motion_test_and_the_orders_see_the_series_without_them():
    """
    Reflections and multipath, no motion: the jumps sway the motion test.

    On the base innovations its p is small (0.0046: at a family-wise 5 % it
    rejected on its own); taken again with the jumps out it is not, and the
    models with jumps have the orders of that series.
    """
    trace = synthetic_trace('reflections+multipath', 1003, 3600)
    split = split_step(trace)
    base = fit_base(split)
    r = base.score(split.train, split.truth)[1]
    assert _motion_family(split, base, r).p_value <= 0.05 / N_TESTS
    family = run_family(split, base)
    assert family.reject['jump_reversal']
    motion = family.tests['motion_dependence']
    assert motion.p_value > 0.05 and family.lag_s is None
    assert 'with the jumps set aside' in motion.test
    # the walk's errors are AR(3); the jumps pass for lost persistence to the PACF rule
    assert sum(abs(p - 3) for p in family.jump_orders) < sum(abs(p - 3) for p in base.orders)
    att = attribute(split, base, family)
    assert att.effects == ['heavy_tails', 'outliers']
    ext = fit_extended(split, base, att)
    assert ext.orders == family.jump_orders
    before, after, _, scored = heldout_measures(split, base, ext, 5, 0, trace.name)
    assert scored == len(base.score(split.test, split.truth,
                                    condition_count(base.orders, ext.orders))[0])
    assert after.heldout_nll_per_sample < before.heldout_nll_per_sample


def test_a_reversal_found_with_the_jumps_in_sets_them_aside_for_the_laws_tests():
    """
    A cycle and reflections: the reversal found with the jumps in stands.

    With the jumps aside the reversal (p 0.004) misses its Holm step
    (0.0333 / 9); with them in it takes it, after the kurtosis of the jumps
    (p 0) and the axis they lie along (coupling, p 0.0016). That rejection
    is a step already taken in the family aside, whose law's tests see no
    tails and no coupling: the effects are the walk's two.
    """
    trace = synthetic_trace('engine_cycle+reflections', 1017, 3600)
    split = split_step(trace)
    base = fit_base(split)
    family = run_family(split, base)
    rev = family.tests['jump_reversal']
    assert rev.given and rev.rejected and rev.p_value > FAMILY_ALPHA / (N_TESTS - 1)
    assert family.tests['periodicity'].rejected
    assert not family.reject['kurtosis'] and not family.reject['cross_axis_correlation']
    assert family.tests['kurtosis'].p_value > 0.05
    given = {'jump_reversal': rev.holm_adjusted_p}
    reject, adjusted = holm({k: t.p_value for k, t in family.tests.items()},
                            FAMILY_ALPHA, given)
    assert reject == family.reject and adjusted == family.adjusted
    att = attribute(split, base, family)
    assert sorted(att.effects) == ['outliers', 'periodic']
    ext = fit_extended(split, base, att)
    before, after, _, _ = heldout_measures(split, base, ext, 5, 0, trace.name)
    assert after.heldout_nll_per_sample < before.heldout_nll_per_sample

"""The test family: oracles from statsmodels, levels, Holm, tails against regimes."""

import numpy as np
import pytest
from scipy import stats
from statsmodels.stats.diagnostic import acorr_ljungbox

from gps_error_ros.diagnose.family import (holm, innovation_tests, ljung_box,
                                           robust_correlation_test,
                                           robust_portmanteau)


def test_ljung_box_on_one_segment_matches_statsmodels():
    x = np.random.default_rng(9).normal(size=500)
    x[1:] += 0.3 * x[:-1]
    q, p, _ = ljung_box(x, np.zeros(500, dtype=int), 10, 10)
    ref = acorr_ljungbox(x, lags=[10])
    assert q == pytest.approx(float(ref['lb_stat'].iloc[0]), rel=1e-10)
    assert p == pytest.approx(float(ref['lb_pvalue'].iloc[0]), rel=1e-8)


def test_ljung_box_does_not_bridge_segments():
    rng = np.random.default_rng(10)
    x = rng.normal(size=600)
    seg = np.r_[np.zeros(300, int), np.ones(300, int)]
    d = x - x.mean()
    acf1 = (d[:299] @ d[1:300] + d[300:599] @ d[301:600]) / (d @ d)
    q, _, acf = ljung_box(x, seg, 1, 1)
    assert acf[0] == pytest.approx(acf1, rel=1e-12)
    assert q == pytest.approx(600 * 602 * acf1 ** 2 / 599, rel=1e-12)
    assert ljung_box(x, np.zeros(600, int), 1, 1)[2][0] != pytest.approx(acf1)


def test_holm_matches_the_step_down_rule():
    p = {'a': 0.01, 'b': 0.04, 'c': 0.03, 'd': 0.2}
    reject, adj = holm(p, 0.05)
    assert reject == {'a': True, 'c': False, 'b': False, 'd': False}
    assert adj['a'] == pytest.approx(0.04)
    assert adj['c'] == pytest.approx(0.09)
    assert adj['b'] == pytest.approx(0.09)          # monotone
    reject, _ = holm({'a': 0.001, 'b': 0.02}, 0.05)
    assert reject == {'a': True, 'b': True}


def test_holm_with_a_given_rejection_steps_down_over_the_rest():
    """A test rejected in another family is a step taken: the rest start at alpha / (m - 1)."""
    p = {'a': 0.02, 'b': 0.024, 'g': 0.3}
    reject, adj = holm(p, 0.05)
    assert not any(reject.values())                 # 0.02 > 0.05 / 3
    reject, adj = holm(p, 0.05, given={'g': 0.03})
    assert reject == {'g': True, 'a': True, 'b': True}     # 0.02 <= 0.05 / 2, 0.024 <= 0.05
    assert adj == pytest.approx({'g': 0.03, 'a': 0.04, 'b': 0.04})
    reject, adj = holm(p, 0.05, given={'g': 0.045})
    assert adj == pytest.approx({'g': 0.045, 'a': 0.045, 'b': 0.045})   # at least the given's
    reject, adj = holm({'a': 0.03, 'g': 0.3}, 0.05, given={'g': 0.01})
    assert reject == {'g': True, 'a': True} and adj['a'] == pytest.approx(0.03)
    reject, adj = holm({'a': 0.06, 'g': 0.3}, 0.05, given={'g': 0.01})
    assert reject == {'g': True, 'a': False} and adj['a'] == pytest.approx(0.06)


def test_robust_tests_keep_their_level_under_changing_variance():
    rng = np.random.default_rng(2)
    rej_lb = rej_cc = 0
    for i in range(200):
        scale = np.exp(np.sin(np.arange(2000) / 150.0 + i))   # slow variance drift
        x = rng.normal(size=(2000, 2)) * scale[:, None]
        seg = np.zeros(2000, dtype=int)
        rej_lb += robust_portmanteau(x[:, 0], seg, 30, 30)[1] < 0.05
        rej_cc += robust_correlation_test(x[:, 0], x[:, 1])[1] < 0.05
    # binomial(200, 0.05): P(X > 20) < 0.01
    assert rej_lb <= 20 and rej_cc <= 20, (rej_lb, rej_cc)


def test_kurtosis_and_persistence_tell_tails_from_regimes():
    """Student-t iid: kurtosis yes, persistence no; regimes: both."""
    rng = np.random.default_rng(5)
    seg = np.zeros(3000, dtype=int)
    t_iid = stats.t.rvs(4, size=(3000, 2), random_state=rng)
    tests = innovation_tests(t_iid, seg, (1, 1))
    assert tests['kurtosis'].p_value < 1e-4
    assert tests['squared_persistence'].p_value > 0.001
    scale = np.repeat(rng.choice([1.0, 3.0], size=30), 100)
    reg = rng.normal(size=(3000, 2)) * scale[:, None]
    tests = innovation_tests(reg, seg, (1, 1))
    assert tests['squared_persistence'].p_value < 1e-6


def test_periodicity_keeps_its_level_and_finds_cycles():
    """Nulls with persistent variance do not reject; a cycle of 7 steps does."""
    from gps_error_ros.diagnose.family import periodicity_test
    rng = np.random.default_rng(21)
    n = 1200
    seg = np.r_[np.zeros(600, int), np.ones(600, int)]
    steps = np.r_[np.arange(600), 650 + np.arange(600)]
    ps = []
    for _ in range(20):           # white, and variance levels lasting ~40 steps
        level = np.repeat(rng.choice([1.0, 3.0], size=n // 40 + 1), 40)[:n]
        ps.append(periodicity_test(rng.normal(size=(n, 2)) * level[:, None], seg, steps,
                                   draws=100).p_value)
    assert np.mean(np.array(ps) <= 0.05) <= 0.15, ps          # 5 % expected; 20 draws
    scale = np.where(steps % 7 == 3, 2.0, 0.85)               # variance, not a sine
    t = periodicity_test(rng.normal(size=(n, 2)) * scale[:, None], seg, steps)
    assert t.p_value < 0.01 and t.whole('at_period') in (7, 14, 21, 28)
    assert t.word('in') == 'variance'
    mean = np.where(steps % 5 < 2, 0.6, -0.4)[:, None]       # a cycle in the mean
    t = periodicity_test(rng.normal(size=(n, 2)) + mean, seg, steps)
    assert t.p_value < 0.01 and t.whole('at_period') % 5 == 0 and t.word('in') == 'mean'


def _ar1(w, phi=0.9):
    x = np.zeros_like(w)
    for t in range(1, len(w)):
        x[t] = phi * x[t - 1] + w[t]
    return x


def test_jump_reversal_tells_jumps_that_come_back_from_tails_and_regimes():
    """Additive jumps pair up in opposite directions; t-innovations and bursts do not."""
    from gps_error_ros.diagnose.family import jump_reversal_test
    rng = np.random.default_rng(11)
    n, seg = 3000, np.zeros(3000, dtype=int)
    level = {'null': [], 'jumps': []}
    for rep in range(40):
        tails = stats.t.rvs(3, size=(n, 2), random_state=rng)
        loud = np.where((np.arange(n) // 100) % 5 == 0, 4.0, 1.0)
        burst = rng.normal(size=(n, 2)) * loud[:, None]
        for w in (tails, burst):
            level['null'].append(jump_reversal_test(w, seg, seed=rep).p_value)
        x = _ar1(rng.normal(size=(n, 2)))
        t0 = rng.choice(n - 5, 30, replace=False)
        for k in t0:                          # jumps of 1-3 steps, 10 SD away
            x[k:k + rng.integers(1, 4)] += rng.normal(0, 10, 2)
        r = x[1:] - 0.9 * x[:-1]              # the AR residuals
        level['jumps'].append(jump_reversal_test(r, seg[1:], seed=rep).p_value)
    # binomial(80, 0.05): P(X > 9) < 0.01
    assert sum(p <= 0.05 for p in level['null']) <= 9, sorted(level['null'])[:12]
    assert all(p <= 0.005 for p in level['jumps']), sorted(level['jumps'])[-5:]


def test_jump_reversal_sees_single_jumps_beside_bursts():
    """Bursts of loud steps pair at random many times; weighted down, they do not drown jumps."""
    from gps_error_ros.diagnose.family import jump_reversal_test
    ps = []
    for rep in range(20):
        rng = np.random.default_rng(rep)
        n = 2000
        r = rng.normal(size=(n, 2))
        for k in rng.choice(np.arange(50, n - 50, 100), 8, replace=False):
            o, length = rng.normal(0, 8, 2), rng.integers(1, 5)
            r[k] += o                       # 8 jumps of 1-4 steps that come back
            r[k + length] -= o
        for k in (20, 520, 1020, 1520):     # four bursts of 8 steps at 10x
            r[k + 3:k + 11] *= 10
        ps.append(jump_reversal_test(r, np.zeros(n, dtype=int), seed=rep).p_value)
    # unweighted (every pair the same say): median p 0.10, and 5 of 20 at most 0.05
    assert np.median(ps) <= 0.01 and sum(p <= 0.05 for p in ps) >= 19, sorted(ps)


def test_jump_reversal_without_large_pairs_is_no_evidence():
    from gps_error_ros.diagnose.family import jump_reversal_test
    r = np.random.default_rng(3).normal(size=(500, 2))
    t = jump_reversal_test(r, np.zeros(500, dtype=int))
    assert t.p_value == 1.0 and t.whole('pairs') == 0


def test_robust_phase_scales_are_not_moved_by_a_few_jumps():
    """A cycle of variance with jumps of metres: the medians keep its shape, the means do not."""
    from gps_error_ros.diagnose.models import phase_scales, robust_phase_scales
    rng = np.random.default_rng(5)
    shape = np.array([2.5, 1.3] + [0.8] * 6)
    n = 2400
    phase = np.arange(n) % 8
    r = rng.normal(size=(n, 2)) * shape[phase][:, None]
    for k in rng.choice(n, 20, replace=False):      # 20 jumps of 15 SDs, at any phase
        r[k] += rng.choice([-1.0, 1.0], 2) * 15.0
    truth = shape / np.sqrt(np.mean(shape ** 2))
    robust = robust_phase_scales(r, phase, 8)
    assert np.max(np.abs(robust / truth - 1.0)) < 0.15, (robust, truth)
    assert np.max(np.abs(phase_scales(r, phase, 8) / truth - 1.0)) > 0.3


def test_motion_max_t_lies_between_one_lag_and_bonferroni():
    """Identical scores: the p of one lag; independent ones: Sidak; Bonferroni bounds both."""
    from gps_error_ros.diagnose.family import motion_test
    lrs = [9.0, 8.0, 7.0, 6.0, 5.0]
    one = 0.5 * stats.chi2.sf(9.0, 1)
    bonferroni = motion_test(lrs).p_value
    assert bonferroni == pytest.approx(5 * one)
    same = motion_test(lrs, np.ones((5, 5))).p_value
    apart = motion_test(lrs, np.eye(5)).p_value
    lag = np.abs(np.subtract.outer(np.arange(5), np.arange(5)))
    near = motion_test(lrs, 0.8 ** lag).p_value
    assert same == pytest.approx(one, rel=0.15)
    assert apart == pytest.approx(1 - (1 - one) ** 5, rel=0.1)
    assert same < near < apart <= bonferroni
    assert motion_test([0.0] * 5, np.eye(5)).p_value == 1.0


def test_motion_scores_correlate_across_lags_on_a_walk():
    """The probes' regressors overlap: neighbouring lags correlate, far ones less."""
    from gps_error_ros.diagnose.mean import motion_correlation
    from gps_error_ros.diagnose.pipeline import fit_base, split_step
    from gps_error_ros.sim.synthetic import synthetic_trace
    split = split_step(synthetic_trace('none', 7, 1200))
    base = fit_base(split)
    c = motion_correlation(split.train, base.orders, split.truth, base.mean.phi, (1.0, 1.0))
    assert c.shape == (5, 5) and np.allclose(c, c.T) and np.allclose(np.diag(c), 1.0)
    assert np.linalg.eigvalsh(c).min() > -1e-9
    assert np.all((np.diag(c, 1) > 0.3) & (np.diag(c, 1) < 0.99)), c
    assert c[0, 4] < c[0, 1], c

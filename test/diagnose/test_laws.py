"""Innovation laws: densities against scipy, the forward filter, EM."""

import numpy as np
import pytest
from scipy import optimize, stats

from gps_error_ros.diagnose.laws import (component_logpdf, fit_law, Law,
                                         law_from_vector, law_logpdf, law_vector,
                                         scan_loglik, stationary_distribution)


def test_densities_match_scipy():
    rng = np.random.default_rng(7)
    r = rng.normal(size=(50, 2)) * [1.5, 0.7]
    cov = np.array([[2.0, 0.6], [0.6, 0.8]])
    gauss = component_logpdf(r, cov, np.inf, 1.0)
    np.testing.assert_allclose(gauss, stats.multivariate_normal(cov=cov).logpdf(r),
                               rtol=1e-12)
    # Student-t with covariance c: scipy's shape matrix is c (dof - 2) / dof
    dof, scale2 = 4.5, 2.3
    ours = component_logpdf(r, cov, dof, scale2)
    ref = stats.multivariate_t(shape=cov * scale2 * (dof - 2) / dof, df=dof).logpdf(r)
    np.testing.assert_allclose(ours, ref, rtol=1e-12)


def test_forward_filter_equals_the_plain_recursion():
    rng = np.random.default_rng(0)
    logf = rng.normal(size=(777, 3))
    trans = np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.2, 0.2, 0.6]])
    pi = np.array([0.5, 0.3, 0.2])
    ll, pred, gamma, counts = scan_loglik(logf, trans, pi, smooth=True)
    a, ref_ll, ref_pred, alphas = pi * np.exp(logf[0]), [], [pi], []
    ref_ll.append(np.log(a.sum()))
    a /= a.sum()
    alphas.append(a)
    for t in range(1, len(logf)):
        p = a @ trans
        ref_pred.append(p)
        a = p * np.exp(logf[t])
        ref_ll.append(np.log(a.sum()))
        a /= a.sum()
        alphas.append(a)
    assert np.allclose(ll, ref_ll, atol=1e-10)
    assert np.allclose(pred, ref_pred, atol=1e-12)
    b = np.ones(3)                                     # plain backward pass
    ref_gamma = [None] * len(logf)
    ref_gamma[-1] = alphas[-1]
    for t in range(len(logf) - 2, -1, -1):
        b = trans @ (np.exp(logf[t + 1]) * b)
        b /= b.sum()
        g = alphas[t] * b
        ref_gamma[t] = g / g.sum()
    assert np.allclose(gamma, ref_gamma, atol=1e-10)
    assert counts.sum() == pytest.approx(len(logf) - 1)


def test_regimes_restart_at_each_segment():
    law = Law(np.eye(2), np.inf, np.array([1.0, 3.0]),
              np.array([[0.9, 0.1], [0.2, 0.8]]))
    r = np.random.default_rng(3).normal(size=(40, 2))
    whole, _ = law_logpdf(law, r, np.zeros(40, dtype=int))
    split, _ = law_logpdf(law, r, np.r_[np.zeros(20, int), np.ones(20, int)])
    assert np.allclose(whole[:20], split[:20])
    first_alone, _ = law_logpdf(law, r[20:], np.zeros(20, dtype=int))
    assert np.allclose(split[20:], first_alone)
    assert not np.allclose(whole[20:], split[20:])


def test_em_reaches_the_likelihood_maximum():
    rng = np.random.default_rng(1)
    regime = np.zeros(3000, dtype=int)
    for t in range(1, 3000):
        regime[t] = regime[t - 1] if rng.random() < 0.98 else 1 - regime[t - 1]
    r = rng.normal(size=(3000, 2)) * np.where(regime, 2.5, 1.0)[:, None]
    seg = np.zeros(3000, dtype=int)
    law = fit_law(r, seg, regimes=2)
    assert law.scales[1] == pytest.approx(2.5, rel=0.1)
    x = law_vector(law, False, False, 2)

    def nll(v):
        return -law_logpdf(law_from_vector(v, False, False, 2), r, seg)[0].sum()

    best = optimize.minimize(nll, x, method='L-BFGS-B')
    assert nll(x) - best.fun < 0.5


def test_segments_in_one_scan_are_each_a_scan_of_their_own():
    rng = np.random.default_rng(1)
    n = 1500
    r = rng.standard_t(5, size=(n, 2))
    seg = np.repeat(np.arange(8), n // 8 + 1)[:n]
    seg[600:700] = 99                          # a segment's samples apart from its order
    law = fit_law(r, seg, coupled=True, tails=True, regimes=3)
    ll, pred = law_logpdf(law, r, seg)
    pi = stationary_distribution(law.transition)
    logf = np.stack([component_logpdf(r, law.cov, law.dof, s * s) for s in law.scales], axis=1)
    for s in np.unique(seg):
        sel = np.flatnonzero(seg == s)
        alone, alone_pred = scan_loglik(logf[sel], law.transition, pi)
        np.testing.assert_allclose(ll[sel], alone, atol=1e-10, rtol=0)
        np.testing.assert_allclose(pred[sel], alone_pred, atol=1e-10, rtol=0)
        np.testing.assert_allclose(pred[sel[0]], pi)


def test_the_compiled_regime_filter_is_the_numpy_scan(monkeypatch):
    """The extra ``fast`` (numba) runs the regimes' recursions step by step, as numpy's scan."""
    from gps_error_ros.diagnose import compiled
    assert compiled.kernel('hmm_forward') is not None, \
        'numba (requirements-fast.txt) is not importable'
    rng = np.random.default_rng(5)
    logf = rng.normal(size=(2000, 3)) * 4.0 - 30.0
    trans = np.array([[0.97, 0.02, 0.01], [0.05, 0.9, 0.05], [0.1, 0.2, 0.7]])
    pi = stationary_distribution(trans)
    starts = np.zeros(2000, dtype=bool)
    starts[[0, 17, 18, 900, 1999]] = True
    got = [scan_loglik(logf, trans, pi, smooth=True), scan_loglik(logf, trans, pi, starts=starts)]
    monkeypatch.setattr(compiled, 'COMPILED', False)
    want = [scan_loglik(logf, trans, pi, smooth=True), scan_loglik(logf, trans, pi, starts=starts)]
    for g, w in zip(got, want):
        for a, b in zip(g, w):
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-10)
    with pytest.raises(ValueError, match='forward filter only'):
        scan_loglik(logf, trans, pi, smooth=True, starts=starts)

"""
``gps_error diagnose``: blind runs on synthetic walks, and its parts.

The quick subset: one seed (the same for every scenario, not chosen by the
outcome) per scenario of :mod:`gps_error_ros.synthetic`. The long run over
a hundred seeds per effect-free scenario is ``make diagnose-long``.
"""

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from scipy import optimize, stats

from gps_error_ros import diagnose as dg
from gps_error_ros.profiles import load_profile
from gps_error_ros.synthetic import SCENARIOS, synthetic_trace, write_trace_csv
from gps_error_ros.trace_io import read_trace_csv

SEED = 1


@pytest.fixture(scope='module')
def results():
    return {}


@pytest.mark.parametrize('scenario', list(SCENARIOS))
def test_blind_attribution(scenario, results):
    expected, unexplained = SCENARIOS[scenario]
    s = dg.diagnose(synthetic_trace(scenario, SEED, 3600), sims=30).summary
    found = [e['name'] for e in s['effects']]
    assert sorted(found) == sorted(expected), (found, s['tests'])
    assert bool(s['unexplained']) == unexplained, s['unexplained']
    before = s['error_before']['heldout_nll_per_sample']
    after = s['error_after']['heldout_nll_per_sample']
    if expected:
        assert after < before, (before, after)
        assert s['improvement']['heldout_nll_per_sample'] == \
            pytest.approx(before - after, abs=1e-5)
    else:
        assert after == before
        assert s['improvement']['ci95'] == [0.0, 0.0]
    for k, t in s['tests'].items():
        assert 0.0 <= t['p_value'] <= 1.0 and t['holm_adjusted_p'] >= t['p_value']


def test_holm_matches_the_step_down_rule():
    p = {'a': 0.01, 'b': 0.04, 'c': 0.03, 'd': 0.2}
    reject, adj = dg.holm(p, 0.05)
    assert reject == {'a': True, 'c': False, 'b': False, 'd': False}
    assert adj['a'] == pytest.approx(0.04)
    assert adj['c'] == pytest.approx(0.09)
    assert adj['b'] == pytest.approx(0.09)          # monotone
    reject, _ = dg.holm({'a': 0.001, 'b': 0.02}, 0.05)
    assert reject == {'a': True, 'b': True}


def test_forward_filter_equals_the_plain_recursion():
    rng = np.random.default_rng(0)
    logf = rng.normal(size=(777, 3))
    trans = np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.2, 0.2, 0.6]])
    pi = np.array([0.5, 0.3, 0.2])
    ll, pred, gamma, counts = dg._scan_loglik(logf, trans, pi, smooth=True)
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


def test_em_reaches_the_likelihood_maximum():
    rng = np.random.default_rng(1)
    regime = np.zeros(3000, dtype=int)
    for t in range(1, 3000):
        regime[t] = regime[t - 1] if rng.random() < 0.98 else 1 - regime[t - 1]
    r = rng.normal(size=(3000, 2)) * np.where(regime, 2.5, 1.0)[:, None]
    seg = np.zeros(3000, dtype=int)
    law = dg.fit_law(r, seg, regimes=2)
    assert law.scales[1] == pytest.approx(2.5, rel=0.1)
    x = dg._law_vector(law, False, False, 2)

    def nll(v):
        return -dg.law_logpdf(dg._unpack(v, False, False, 2), r, seg)[0].sum()

    best = optimize.minimize(nll, x, method='L-BFGS-B')
    assert nll(x) - best.fun < 0.5


def test_robust_tests_keep_their_level_under_changing_variance():
    rng = np.random.default_rng(2)
    rej_lb = rej_cc = 0
    for i in range(200):
        scale = np.exp(np.sin(np.arange(2000) / 150.0 + i))   # slow variance drift
        x = rng.normal(size=(2000, 2)) * scale[:, None]
        seg = np.zeros(2000, dtype=int)
        rej_lb += dg.robust_portmanteau(x[:, 0], seg, 30, 30)[1] < 0.05
        rej_cc += dg.robust_correlation_test(x[:, 0], x[:, 1])[1] < 0.05
    # binomial(200, 0.05): P(X > 20) < 0.01
    assert rej_lb <= 20 and rej_cc <= 20, (rej_lb, rej_cc)


def test_too_short_trace_is_refused_with_the_reason():
    tr = synthetic_trace('none', 0, 300)
    with pytest.raises(dg.DiagnosisError) as exc:
        dg.diagnose(tr, sims=5)
    assert 'training' in str(exc.value) and 'need at least' in str(exc.value)


def test_cli_writes_json_report_and_a_profile_the_node_can_load(tmp_path):
    walk = write_trace_csv(synthetic_trace('street_ellipse', 3, 2400),
                           tmp_path / 'walk.csv')
    assert len(read_trace_csv(walk)) > 2000
    out = subprocess.run(
        [sys.executable, '-m', 'gps_error_ros.cli', 'diagnose', str(walk),
         '--json', str(tmp_path / 'd.json'), '--report', str(tmp_path / 'r'),
         '--profile-out', str(tmp_path / 'ext.yaml'), '--sims', '20'],
        capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    d = json.loads((tmp_path / 'd.json').read_text())
    for key in ('input', 'samples', 'train_samples', 'test_samples', 'base',
                'effects', 'unexplained', 'error_before', 'error_after'):
        assert key in d
    assert d['samples'] == d['train_samples'] + d['test_samples']
    assert d['base']['order']['north'] >= 1
    for side in ('error_before', 'error_after'):
        m = d[side]
        assert math.isfinite(m['heldout_nll_per_sample'])
        assert {'acf_distance', 'ne_correlation', 'horizontal_quantiles_m'} <= set(m)
    png = (tmp_path / 'r' / 'diagnosis.png').read_bytes()
    assert png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 20000
    prof = load_profile(str(tmp_path / 'ext.yaml'))
    assert prof.effects.names == tuple(e['name'] for e in d['effects'])
    assert 'cross_axis_coupling' in prof.effects.names
    cov = prof.model().stationary_cov
    assert cov[0, 1] > 0                       # ellipse along the 29 deg avenues
    bad = subprocess.run(
        [sys.executable, '-m', 'gps_error_ros.cli', 'diagnose',
         str(tmp_path / 'missing.csv')], capture_output=True, text=True)
    assert bad.returncode == 2 and 'missing.csv' in bad.stderr


def test_kurtosis_and_persistence_tell_tails_from_regimes():
    """Student-t iid: kurtosis yes, persistence no; regimes: both."""
    rng = np.random.default_rng(5)
    seg = np.zeros(3000, dtype=int)
    t_iid = stats.t.rvs(4, size=(3000, 2), random_state=rng)
    tests = dg.innovation_tests(t_iid, seg, (1, 1))
    assert tests['kurtosis']['p_value'] < 1e-4
    assert tests['squared_persistence']['p_value'] > 0.001
    scale = np.repeat(rng.choice([1.0, 3.0], size=30), 100)
    reg = rng.normal(size=(3000, 2)) * scale[:, None]
    tests = dg.innovation_tests(reg, seg, (1, 1))
    assert tests['squared_persistence']['p_value'] < 1e-6


def test_baseline_classes_fit_and_score_the_same_samples():
    from scipy import signal
    from gps_error_ros.baselines import Arma11, CLASSES, compare
    from gps_error_ros.diagnose import Part
    rng = np.random.default_rng(4)
    segs = []
    for _ in range(2):
        w = rng.normal(size=(3000, 2))
        x = np.stack([signal.lfilter([1, -0.4], [1, -0.8], w[:, a]) for a in range(2)], 1)
        segs.append(x[500:] + [1.0, -2.0])
    part = Part(segs, [np.zeros_like(s) for s in segs], [np.arange(len(s)) for s in segs])
    arma = Arma11().fit(part, 5)
    for mu, phi, theta, var in arma.params:
        assert phi == pytest.approx(0.8, abs=0.05)
        assert theta == pytest.approx(-0.4, abs=0.07)
        assert var == pytest.approx(1.0, rel=0.05)
    d = dg.diagnose(synthetic_trace('street_ellipse', 2, 2400), sims=10)
    table = compare(d, sims=10)
    assert list(table) == list(CLASSES)
    nll = {k: v['heldout_nll_per_sample'] for k, v in table.items()}
    assert nll['extended'] == pytest.approx(d.summary['error_after']['heldout_nll_per_sample'])
    assert nll['AR(p), PACF'] == pytest.approx(d.summary['error_before']['heldout_nll_per_sample'])
    assert nll['white noise + bias'] > nll['AR(p), PACF']

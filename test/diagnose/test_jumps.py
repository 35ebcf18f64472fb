"""Fitting the outliers effect: the filter that sets jumps aside, and its likelihood."""

import numpy as np
import pytest

from gps_error_ros.diagnose.jumps import broken_segments, run_filter, run_filters
from gps_error_ros.model.outliers import Outliers
from gps_error_ros.diagnose.models import fit_model, select_orders
from gps_error_ros.diagnose.pipeline import _orders_without_jumps, split_step
from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import AxisParams
from gps_error_ros.model.effects import build_model, effects_from_dict
from gps_error_ros.model.geodesy import offset
from gps_error_ros.traces.trace_io import Trace

TRUE = {'rate': 0.012, 'mean_steps': 2.5, 'sigma_m': 10.0}
AXIS = AxisParams(0.5, (1.1, -0.05, -0.12), 1.4)
DATUM = (40.75, -73.99)


@pytest.fixture(scope='module')
def fitted():
    """Return a fit on a standing walk whose errors the library simulates with jumps."""
    model = build_model(AXIS, AXIS, effects_from_dict({'outliers': TRUE}))
    err = model.simulate(np.array([streams.agent_key(21, 'jumpy')], dtype=np.uint64),
                         4000)[:, 0]
    t = np.arange(4000, dtype=float)
    lat, lon = offset(DATUM[0], DATUM[1], err[:, 0], err[:, 1])
    ones = np.ones(t.size)
    trace = Trace('jumpy', t, lat, lon, DATUM[0] * ones, DATUM[1] * ones)
    split = split_step(trace)
    # the true orders: the PACF rule on a trace with jumps picks others
    base = fit_model(split.train, (3, 3), (), split.truth)
    return split, base, fit_model(split.train, (3, 3), ('outliers',), split.truth)


def test_the_fit_recovers_the_jumps_and_the_ar_part(fitted):
    _, base, m = fitted
    assert m.jumps.rate == pytest.approx(TRUE['rate'], rel=0.35)
    assert m.jumps.mean_steps == pytest.approx(TRUE['mean_steps'], rel=0.35)
    assert m.jumps.sigma_m == pytest.approx(TRUE['sigma_m'], rel=0.2)
    # the base model's AR part is dragged down by the jumps; the filter's is not
    for a in range(2):
        assert m.mean.phi[a][0] == pytest.approx(1.1, abs=0.05)
        assert abs(base.mean.phi[a][0] - 1.1) > abs(m.mean.phi[a][0] - 1.1)
    assert np.sqrt(m.law.cov[0, 0]) == pytest.approx(1.4, rel=0.1)
    assert m.bic < base.bic
    assert m.parameters()['effects']['outliers']['sigma_m'] == pytest.approx(
        m.jumps.sigma_m, rel=1e-5)


def test_heldout_likelihood_is_better_and_a_proper_density(fitted):
    split, base, m = fitted
    ll_b = base.score(split.test, split.truth)[0]
    ll_m, r, d, _ = m.score(split.test, split.truth)
    assert np.isfinite(ll_m).all() and len(ll_m) == len(ll_b)
    assert ll_m.mean() > ll_b.mean() + 0.1
    # the residuals returned have the jumps out: no gross outliers left
    assert np.max(np.abs(r)) < 8 * np.sqrt(m.law.cov[0, 0])


def test_filter_weights_are_a_distribution_and_depend_on_the_past_only():
    rng = np.random.default_rng(4)
    r = rng.normal(size=(400, 2))
    r[100:103] += (15.0, -12.0)          # white noise (phi 0): the jump shows as it is
    seg = np.r_[np.zeros(250, int), np.ones(150, int)]
    params = Outliers(0.01, 3.0, 10.0)
    jf = run_filter(r, seg, [np.array([0.0]), np.array([0.0])], np.eye(2), params)
    assert np.all(jf.prior >= 0) and np.allclose(jf.prior.sum(axis=1), 1.0)
    assert jf.inside[100] > 0.99 and jf.inside[101] > 0.9 and jf.inside[103] < 0.1
    np.testing.assert_allclose(jf.offset[101], (15.0, -12.0), atol=1.5)
    assert jf.prior[250, 2] == 0.01 and jf.prior[250, 1] == jf.prior[250, 3] == 0.0  # starts clean
    changed = r.copy()
    changed[200:] += 50.0                       # the future does not move the past
    again = run_filter(changed, seg, [np.array([0.0]), np.array([0.0])], np.eye(2), params)
    np.testing.assert_array_equal(again.prior[:201], jf.prior[:201])
    np.testing.assert_array_equal(again.r[:200], jf.r[:200])


def test_candidates_stepped_together_match_each_run_alone():
    rng = np.random.default_rng(7)
    r = rng.standard_t(5, size=(600, 2))
    r[200:203] += (9.0, 11.0)
    seg = np.r_[np.zeros(300, int), np.ones(300, int)]
    phi = [np.array([1.1, -0.05, -0.12]), np.array([0.9])]
    cov = np.array([[1.0, 0.3], [0.3, 2.0]])
    scale2 = rng.choice([0.5, 1.0, 2.0], 600)
    cands = [(Outliers(0.01, 3.0, 10.0), np.inf), (Outliers(0.002, 1.5, 5.0), 4.0),
             (Outliers(0.05, 12.0, 20.0), 30.0)]
    together = run_filters(r, seg, phi, cov, cands, scale2)
    for (params, dof), jf in zip(cands, together):
        alone = run_filter(r, seg, phi, cov, params, scale2, dof)
        for name in ('r', 'r_from', 'prior', 'offset', 'inside', 'post', 'jump_ll'):
            np.testing.assert_allclose(getattr(jf, name), getattr(alone, name),
                                       rtol=1e-12, atol=1e-12, err_msg=name)
    # the candidates differ: the batch does not hand one candidate's pass to all
    assert not np.allclose(together[0].post, together[2].post)


def test_tails_and_jumps_are_fitted_together():
    """Student-t innovations (which persist) and jumps (which come back) in one walk."""
    model = build_model(AXIS, AXIS, effects_from_dict(
        {'heavy_tails': {'dof': 4.0}, 'outliers': TRUE}))
    err = model.simulate(np.array([streams.agent_key(22, 'both')], dtype=np.uint64),
                         4000)[:, 0]
    t = np.arange(4000, dtype=float)
    lat, lon = offset(DATUM[0], DATUM[1], err[:, 0], err[:, 1])
    ones = np.ones(t.size)
    split = split_step(Trace('both', t, lat, lon, DATUM[0] * ones, DATUM[1] * ones))
    m = fit_model(split.train, (3, 3), ('heavy_tails', 'outliers'), split.truth)
    assert m.law.dof == pytest.approx(4.0, rel=0.25)
    # with tails beside them, the time spent in jumps and their size are found;
    # how that time splits into rate and length is weakly told apart (short jumps
    # close together, or fewer longer ones), so the split is held to a factor 2.5
    assert m.jumps.share == pytest.approx(Outliers(**TRUE).share, rel=0.4)
    assert m.jumps.sigma_m == pytest.approx(TRUE['sigma_m'], rel=0.3)
    assert TRUE['rate'] / 2.5 < m.jumps.rate < TRUE['rate'] * 2.5
    tails_only = fit_model(split.train, (3, 3), ('heavy_tails',), split.truth)
    assert m.bic < tails_only.bic


def test_the_tests_see_neither_end_of_a_jump():
    """A jump's start and the step at which it ends are set aside, the segment broken there."""
    rng = np.random.default_rng(4)
    r = rng.normal(size=(400, 2))
    phi = [np.array([0.9]), np.array([0.9])]
    o = np.array([15.0, -12.0])      # an offset on steps 100-102, residuals against the
    r[100] += o                      # uncleaned AR(1) prediction: the start shows whole,
    r[101:103] += 0.1 * o            # the steps inside by 1 - phi, the return by -phi
    r[103] -= 0.9 * o
    seg = np.r_[np.zeros(250, int), np.ones(150, int)]
    jf = run_filter(r, seg, phi, np.eye(2), Outliers(0.01, 3.0, 10.0))
    aside = jf.aside()
    assert jf.inside[102] > 0.9 and jf.inside[103] < 0.1
    assert aside[100:104].all()                      # start, inside, and the end
    assert not aside[99] and not aside[104:110].any()
    assert aside.sum() < 12                          # nothing much besides
    keep = ~aside
    new = np.full(400, -1)
    new[keep] = broken_segments(seg, keep)
    assert new[104] == new[99] + 1                   # a break after the jump
    assert new[250] == new[249] + 1                  # and at the trace's own
    assert (np.diff(new[keep]) >= 0).all() and (np.diff(new[keep]) <= 1).all()
    assert new[keep].max() == 2 + (np.diff(np.flatnonzero(keep)) > 1).sum() - 1


def test_the_orders_are_chosen_on_the_series_without_its_jumps(fitted):
    """A jump looks like a loss of persistence to the PACF rule; with the jumps out it is not."""
    split, _, _ = fitted
    raw = select_orders(split.train)
    assert raw != (3, 3)
    jumpy = fit_model(split.train, raw, ('outliers',), split.truth)   # as the diagnosis does
    assert _orders_without_jumps(split, jumpy, jumpy.jump_filter(split.train, split.truth)[0]) \
        == (3, 3)


def test_a_large_innovation_that_persists_is_not_followed_as_a_long_jump():
    # near a unit root a jump that goes on is, step after step, nearly as likely as a
    # large innovation that persists; the clean state keeps the second path and takes
    # over (a filter that kept only the jump's path followed it for all 61 steps)
    rng = np.random.default_rng(11)
    n, phi = 400, 0.98
    w = rng.normal(size=(n, 2))
    w[100] += (9.0, -7.0)
    x = np.zeros((n, 2))
    for t in range(1, n):
        x[t] = phi * x[t - 1] + w[t]
    e = x.copy()
    e[250:253] += (-10.0, 8.0)                  # a jump of three fixes
    r_obs = e[1:] - phi * e[:-1]
    jf = run_filter(r_obs, np.zeros(n - 1, int), [np.array([phi])] * 2, np.eye(2),
                    Outliers(0.01, 5.0, 10.0), dof=4.0)
    assert (jf.inside[99:160] > 0.5).sum() <= 5
    assert np.all(jf.inside[249:252] > 0.5) and np.all(jf.inside[252:256] < 0.1)
    np.testing.assert_allclose(jf.offset[250], (-10.0, 8.0), atol=3.0)


def test_the_search_scores_a_bounded_sample_of_a_long_part():
    """Up to SEARCH_SAMPLES: everything, as it is; beyond: evenly spread blocks, each a segment."""
    from gps_error_ros.diagnose.mean import Design
    from gps_error_ros.diagnose.models import SEARCH_BLOCKS, SEARCH_SAMPLES, search_sample

    def part(n):
        r = np.arange(2.0 * n).reshape(n, 2)
        seg = np.repeat([0, 1], [n // 3, n - n // 3])
        return r, Design(r.copy(), [r[:, :1], r[:, 1:]], seg, None, np.arange(n))

    r, d = part(SEARCH_SAMPLES)
    assert search_sample(r, d) == (r, d)            # the same objects: results unchanged
    r, d = part(60000)
    rs, ds = search_sample(r, d)
    size = SEARCH_SAMPLES // SEARCH_BLOCKS
    assert len(rs) == len(ds.y) == size * SEARCH_BLOCKS
    starts = rs[::size, 0] / 2
    assert starts[0] == 0 and starts[-1] == 60000 - size and np.all(np.diff(starts) > size)
    assert len(np.unique(ds.seg)) >= SEARCH_BLOCKS     # no block joins the next
    assert np.all(np.diff(ds.seg) >= 0) and np.array_equal(ds.steps, rs[:, 0] / 2)


def test_the_compiled_loop_is_the_numpy_loop(monkeypatch):
    """The extra ``fast`` (numba, which make setup installs) steps the filter as numpy does."""
    from gps_error_ros.diagnose import compiled
    assert compiled.kernel('step_candidates') is not None, \
        'numba (requirements-fast.txt) is not importable'
    rng = np.random.default_rng(11)
    n = 900
    r = rng.standard_t(4, size=(n, 2))
    r[100:104] += (12.0, -7.0)
    r[500] += (-20.0, 3.0)
    seg = np.repeat([0, 1, 2], [400, 3, n - 403])      # a segment shorter than the AR order
    phi = [np.array([0.8, 0.1, -0.05, 0.02]), np.array([0.95, -0.1])]
    cov = np.array([[1.5, -0.4], [-0.4, 0.8]])
    scale2 = rng.choice([0.25, 1.0, 4.0], n)
    cands = [(Outliers(rate, steps, size), dof) for rate in (0.001, 0.05)
             for steps in (1.5, 12.0) for size in (3.0, 24.0) for dof in (np.inf, 3.0)]
    fast = run_filters(r, seg, phi, cov, cands, scale2)
    one = run_filter(r, seg, phi, cov, cands[5][0], scale2, cands[5][1])
    monkeypatch.setattr(compiled, 'COMPILED', False)
    assert compiled.kernel('step_candidates') is None
    in_numpy = run_filters(r, seg, phi, cov, cands, scale2)
    in_floats = run_filter(r, seg, phi, cov, cands[5][0], scale2, cands[5][1])
    fields = ('r', 'r_from', 'prior', 'offset', 'inside', 'post', 'jump_ll')
    for a, b in zip(fast, in_numpy):
        for name in fields:
            np.testing.assert_allclose(getattr(a, name), getattr(b, name),
                                       rtol=1e-12, atol=1e-12, err_msg=name)
    for name in fields:
        np.testing.assert_allclose(getattr(one, name), getattr(in_floats, name),
                                   rtol=1e-12, atol=1e-12, err_msg=name)
    # the candidates differ, and a jump of metres is found at once by the middle one
    assert not np.allclose(fast[0].post, fast[-1].post)
    jf = run_filter(r, seg, phi, cov, Outliers(0.01, 3.0, 10.0), scale2)
    assert jf.inside[99] < 0.5 < jf.inside[100:104].min()

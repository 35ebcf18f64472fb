"""Splits across stretches and recordings, the population class's score, the consumers."""

import numpy as np
import pytest
from scipy import stats

from gps_error_ros.judge.consumers import CONFLICT_M, run_filter, v2p_warnings
from gps_error_ros.fit.fidelity import run_masks, score_differences
from gps_error_ros.judge.beaten import block_orders, FAR_SD, part_pacf, where_beaten
from gps_error_ros.judge.fold_summary import own_verdict, precedent_line
from gps_error_ros.judge.generalise import (_outage_masks, own_shares, recording_splits,
                                            rolling_splits, split_between, training_windows)
from gps_error_ros.judge.population_class import (_kalman_ll, bias_grid, mixture_forward,
                                                  scale_nodes, within_part)
from gps_error_ros.fit.holdout import Part
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.model.population import Population
from gps_error_ros.traces.trace_io import join_recordings, Trace


def _trace(name, n, seed, t0=0.0, place=None):
    """Return a recording along a track of its own (``place``: that of another seed)."""
    rng = np.random.default_rng(seed)
    lat = 40.0 + np.arange(n) * 1e-5            # walking north, 1.1 m/s
    lon = np.full(n, -73.9 + 1e-3 * (seed if place is None else place))
    return Trace(name=name, t=t0 + np.arange(n, dtype=float),
                 lat=lat + rng.normal(0, 2e-5, n), lon=lon + rng.normal(0, 2e-5, n),
                 truth_lat=lat, truth_lon=lon)


def _walk(n, dt=1.0):
    t = np.arange(n) * dt
    truth = np.stack([1.2 * t, 0.3 * t], axis=1)
    return Part([np.zeros((n, 2))], [truth], [t])


def test_rolling_folds_train_before_and_hold_out_the_next_block():
    trace = _trace('a', 1000, 0)
    folds = rolling_splits(trace, origins=(0.5, 0.75), horizon=0.25)
    assert [s.train.n for _, s in folds] == [500, 750]
    assert [s.test.n for _, s in folds] == [250, 250]
    last_train = max(t[-1] for t in folds[0][1].train.t)
    assert last_train < folds[0][1].test.t[0][0]


def test_leaving_one_recording_out_holds_out_exactly_that_recording():
    traces = [_trace('a', 300, 1), _trace('b', 400, 2), _trace('c', 200, 3)]
    folds = recording_splits(traces)
    assert [label for label, _ in folds] == ['without a', 'without b', 'without c']
    assert [s.test.n for _, s in folds] == [300, 400, 200]
    assert [s.train.n for _, s in folds] == [600, 500, 700]
    assert all(s.train_weights == (1.0,) * len(s.train.t) for _, s in folds)


def test_recordings_made_together_never_train_for_each_other():
    """Recordings b and c are two receivers on one walk: holding out one, neither trains."""
    traces = [_trace('a', 300, 1), _trace('b', 400, 2), _trace('c', 400, 3, place=2),
              _trace('d', 200, 4)]
    folds = recording_splits(traces)
    assert [label for label, _ in folds] == [
        'without a', 'without b (nor the 1 recorded with it)',
        'without c (nor the 1 recorded with it)', 'without d']
    assert [s.test.n for _, s in folds] == [300, 400, 400, 200]
    assert [s.train.n for _, s in folds] == [1000, 500, 500, 1100]
    # where both train, each weighs a half: one occasion, one draw of the bias
    a_fold = folds[0][1]
    assert sorted(set(a_fold.train_weights)) == [0.5, 1.0]
    assert sum(w * len(t) for w, t in zip(a_fold.train_weights, a_fold.train.t)) == 600


def test_the_population_score_is_the_exact_gaussian_likelihood():
    """AR(2) plus a constant bias: the filter's densities sum to the joint log density."""
    phi, sw, bias_sd = (0.6, 0.2), 1.3, 2.0
    rng = np.random.default_rng(5)
    n = 80
    y = rng.normal(0, 3, (n, 2))
    part = Part([y[:50], y[50:]], [np.zeros((50, 2)), np.zeros((30, 2))],
                [np.arange(50.0), 53.0 + np.arange(30.0)])       # a gap of 3 steps
    ll = _kalman_ll(part, 0, np.array(phi), sw, 0.4, bias_sd, 1.0).sum()
    model = ARErrorModel(AxisParams(0.0, phi, sw), AxisParams(0.0, phi, sw))
    acv = model.autocovariance(90)[:, 0, 0]
    t = np.concatenate(part.t).astype(int)
    cov = acv[np.abs(np.subtract.outer(t, t))] + bias_sd ** 2
    want = stats.multivariate_normal(np.full(n, 0.4), cov).logpdf(y[:, 0])
    assert abs(ll - want) < 1e-8


def test_the_mixture_score_is_the_marginal_likelihood_over_its_nodes():
    """A bias fixed for the run: the one-step densities sum to the prior-weighted joint one."""
    rng = np.random.default_rng(8)
    lls = rng.normal(-2.0, 1.0, (3, 5, 40))
    log_scale, log_bias = np.log([0.2, 0.5, 0.3]), np.log(np.full(5, 0.2))
    t = np.arange(40.0)
    got = mixture_forward(lls, log_scale, log_bias, t, 1.0).sum()
    want = np.logaddexp.reduce(log_scale[:, None] + log_bias[None, :] + lls.sum(axis=2),
                               axis=None)
    assert abs(got - want) < 1e-9
    # a bias redrawn at every step: each sample is scored by the prior mixture
    # given only the scale learnt so far
    fresh = mixture_forward(lls[:1], np.zeros(1), log_bias, t, 1e-300)
    mix = np.logaddexp.reduce(log_bias[:, None] + lls[0], axis=0)
    assert np.allclose(fresh, mix)


def test_the_scale_grid_resolves_a_long_runs_scale():
    """
    A run of known scale costs the mixture little more than the price of not knowing it.

    Averaged over the scale's law, the score of 400 samples pays about
    ``0.5 log n`` (3.0 nats) plus the prior's density at the truth against
    the score with the scale known; a few Gauss-Hermite nodes, which leave
    ``f = 1`` between two of them, pay far more (8.1 nats here).
    """
    rng = np.random.default_rng(3)
    y = rng.normal(0.0, 1.0, 400)
    known = stats.norm.logpdf(y).sum()
    f, log_f = scale_nodes(0.35)
    lls = np.array([[stats.norm.logpdf(y, 0.0, s)] for s in f])
    cost = known - mixture_forward(lls, log_f, np.zeros(1), np.arange(400.0), 1.0).sum()
    assert 0.0 < cost < 0.5 * np.log(400) + 0.5, cost


def test_the_population_laws_on_their_nodes():
    pop = Population((1.5, 3.0), 0.3)
    nodes, log_w = bias_grid(pop)
    w = np.exp(log_w)
    assert abs(w.sum() - 1.0) < 1e-12
    assert np.allclose(np.sqrt(w @ nodes ** 2), (1.5, 3.0), rtol=0.02)
    heavy = bias_grid(Population((1.5, 3.0), 0.3, bias_dof=3))[1]
    far = np.abs(nodes[:, 1]) > 9.0
    assert np.exp(heavy[far]).sum() > 3 * w[far].sum()         # the t law's tails
    f, log_f = scale_nodes(0.3)
    assert abs(np.exp(log_f) @ f ** 2 - 1.0) < 1e-3              # E f^2 = 1, as the model
    assert scale_nodes(0.0)[0].tolist() == [1.0]
    assert bias_grid(Population((0.0, 2.0), 0.0))[0].shape == (21, 2)


def test_training_windows_tell_a_held_out_stretch_without_precedent():
    rng = np.random.default_rng(4)
    err = rng.normal(0.0, 1.0, (600, 2))
    train = Part([err[:400], err[400:]], [np.zeros((400, 2)), np.zeros((200, 2))],
                 [np.arange(400.0), 500.0 + np.arange(200.0)])     # two runs
    test = Part([rng.normal(0.0, 1.0, (300, 2)) + (5.0, 0.0)], [np.zeros((300, 2))],
                [1000.0 + np.arange(300.0)])
    w = training_windows(train, test)
    # the 400-s run holds one window of 299 s (the next would start at 149.5 s and
    # pass its end); the 200-s run, shorter than that, counts whole
    assert w['windows'] == 2 and w['span_s'] == 299.0
    lo, hi = w['range']['bias:mean_north']
    assert hi < 1.0 < 5.0                                   # a new bias: no precedent
    # the line compare --folds prints: the misses, and those that nothing in training was like
    row = {'measured': 5.0, 'sim_lo': -1.0, 'sim_hi': 1.0}
    scale = {'measured': 1.5, 'sim_lo': 0.8, 'sim_hi': 1.2}
    fold = {'fold': 'f1', 'train_windows': w, 'classes': {'population': {'measures': {
        'bias:mean_north': row, 'scale:sd_north': scale, 'filter:filter_rms': row}}}}
    w['range']['scale:sd_north'] = [0.9, 1.6]               # a window had that scale
    line = precedent_line([fold])
    assert line.endswith('(population): 2, of which 1 outside every training window like the '
                         'held-out part as well (no precedent): f1 mean_north'), line
    fold['classes']['population']['measures'] = {'filter:filter_rms': row}   # consumers'
    assert precedent_line([fold]) is None
    lo, hi = w['range']['scale:sd_east']
    assert lo < 1.0 < hi


def _without(trace, rows):
    """Return ``trace`` without the given rows (an outage where they are consecutive)."""
    keep = np.ones(len(trace.t), dtype=bool)
    keep[list(rows)] = False
    return Trace(name=trace.name, t=trace.t[keep], lat=trace.lat[keep], lon=trace.lon[keep],
                 truth_lat=trace.truth_lat[keep], truth_lon=trace.truth_lon[keep])


def test_outages_are_judged_where_a_part_has_them_and_joins_are_none():
    gappy = [_without(_trace('a', 400, 1), range(100, 104)), _trace('b', 400, 2),
             _without(_trace('c', 300, 3), range(50, 53))]
    _, split = recording_splits(gappy)[2]                        # c held out
    masks = run_masks(split.train)
    assert [m.size for m in masks] == [400, 400]                 # the join is no outage
    assert [int((~m).sum()) for m in masks] == [4, 0]
    model = ARErrorModel(AxisParams(0.0, (0.5,), 1.0), AxisParams(0.0, (0.5,), 1.0))
    out = _outage_masks(split, ['ar1', 'extended', 'population'], model, 30, 0)
    assert out['ar1'] == 'none'                                  # a fix at every step
    assert out['extended'].shape == (30, 300) and out['population'] is out['extended']
    assert (~out['extended']).any()                              # the training gap's rate
    clean = [_trace('a', 400, 1), _trace('b', 400, 2), _trace('c', 300, 3)]
    assert _outage_masks(recording_splits(clean)[2][1], ['ar1'], model, 30, 0) is None


def test_the_filter_is_consistent_on_errors_it_was_told():
    part = _walk(3000)
    rng = np.random.default_rng(2)
    var = np.array([4.0, 9.0])
    errors = np.stack([np.zeros((3000, 2)), rng.normal(0, np.sqrt(var), (3000, 2))])
    rms, p95, nees, gate = run_filter(part, errors, var).T
    # exact fixes: the filter only carries its velocity aid's drift, and trusts itself less
    assert rms[0] < rms[1] and gate[0] == 0.0 and nees[0] < 1.0
    # white errors of the stated variance: NEES a little under 2 (the truth keeps its
    # velocity, the filter allows for accelerations), the gate rejects about 1 %
    assert 1.3 < nees[1] < 2.2, nees
    assert 0.004 < gate[1] < 0.02, gate
    assert rms[1] < np.sqrt(var.sum())


def test_what_a_filters_error_is_made_of():
    """The mean's size and the SD apart, and the filter's response to the rest per SD."""
    from gps_error_ros.judge.consumers import filter_parts
    n = 1500
    part = _walk(n)
    rng = np.random.default_rng(4)
    sims = [[rng.normal(0, 3.0, (n, 2))] for _ in range(60)]      # white, no mean
    white = rng.normal(0, 3.0, (n, 2))
    train = [rng.normal(0, 3.0, (n, 2))]
    plain = filter_parts(part, [white], sims, train)
    moved = filter_parts(part, [white + [4.0, -3.0]], sims, train)
    assert moved['mean_size_m']['measured'] == pytest.approx(5.0, abs=0.3)
    assert moved['mean_size_m']['percentile'] == 100.0         # white sims: means of ~0.1 m
    # the bias goes into the mean's size alone: the SD and the response are the same
    for k in ('sd_m', 'filter_rms_per_sd'):
        assert moved[k]['measured'] == pytest.approx(plain[k]['measured'], rel=1e-9)
    assert 2.5 <= plain['filter_rms_per_sd']['percentile'] <= 97.5
    # a persistent error of the same SD: the filter lets much more of it through
    ar = np.zeros((n, 2))
    z = rng.normal(0, 3.0 * np.sqrt(1 - 0.99 ** 2), (n, 2))
    for i in range(1, n):
        ar[i] = 0.99 * ar[i - 1] + z[i]
    slow = filter_parts(part, [ar - ar.mean(axis=0)], sims, train)
    assert slow['filter_rms_per_sd']['percentile'] == 100.0
    assert slow['filter_rms_per_sd']['measured'] > 2 * plain['filter_rms_per_sd']['measured']


def _ar1(rho, n, rng):
    """Return an AR(1) (n, 2) of unit variance."""
    x = np.zeros((n, 2))
    z = rng.normal(0.0, np.sqrt(1.0 - rho * rho), (n, 2))
    x[0] = rng.normal(0.0, 1.0, 2)
    for i in range(1, n):
        x[i] = rho * x[i - 1] + z[i]
    return x


def test_a_persistence_that_moves_from_block_to_block_is_found():
    """Blocks of ACF 0.95 and 0.2 in turn lie beyond one AR's spread; that AR's own do not."""
    from gps_error_ros.judge.window_persistence import (
        persistence_spread, spread_line, window_acf1)
    rng = np.random.default_rng(7)
    block, blocks = 300, 8
    t = np.arange(block * blocks, dtype=float)
    part = _walk(t.size)
    mixed = np.concatenate([_ar1(0.95 if b % 2 else 0.2, block, rng) for b in range(blocks)])
    acf = window_acf1([mixed], [t])
    assert acf.shape == (blocks, 2)
    assert np.all(acf[1::2] > 0.8) and np.all(acf[::2] < 0.4)
    # a gap within a block: no lag product across it
    cut = window_acf1([mixed[:150], mixed[150:]], [t[:150], t[150:]])
    assert cut[0, 0] != acf[0, 0] and np.allclose(cut[1:], acf[1:])
    sims = [[_ar1(0.6, t.size, rng)] for _ in range(60)]
    found = persistence_spread(Part([mixed], part.truth, [t]), sims)
    assert found['windows'] == blocks
    for ax in ('north', 'east'):
        assert found[f'acf1_sd_{ax}']['percentile'] == 100.0
        assert found[f'lowest_acf1_{ax}']['percentile'] < 2.5
    own = persistence_spread(Part([_ar1(0.6, t.size, rng)], part.truth, [t]), sims)
    for ax in ('north', 'east'):
        assert 2.5 <= own[f'acf1_sd_{ax}']['percentile'] <= 97.5
    short = Part([mixed[:2 * block]], [part.truth[0][:2 * block]], [t[:2 * block]])
    assert persistence_spread(short, sims) is None      # two blocks: no spread to judge
    folds = [{'fold': 'f1', 'classes': {'population': {'persistence_spread': found}}},
             {'fold': 'f2', 'classes': {'population': {'persistence_spread': own}}},
             {'fold': 'f3', 'classes': {'population': {'persistence_spread': None}}}]
    line = spread_line(folds)
    assert 'above the range on 2 of 4 fold axes: f1 north ' in line and 'f2' not in line
    assert spread_line(folds[1:]).endswith('above the range on 0 of 2 fold axes')
    assert spread_line(folds[2:]) is None


def test_v2p_warnings_on_exact_positions():
    """No error: every conflict warned, and a third of the rest (within W + s of W + 3s)."""
    part = _walk(20000)
    hit, false = v2p_warnings(part, np.zeros((1, 20000, 2)), 1.5)[0]
    assert hit == 1.0
    assert abs(false - 1.0 / 3.0) < 0.02
    big = v2p_warnings(part, np.full((1, 20000, 2), 50.0), 1.5)[0]
    assert big[0] < 0.2 and CONFLICT_M > 0


def test_a_classes_own_traces_are_judged_as_the_real_one():
    """Each simulated trace inside its own range about 95 % of the time, group by group."""
    rng = np.random.default_rng(2)
    values = {f'bias:m{j}': rng.normal(size=400) for j in range(2)}
    values.update({f'filter:f{j}': rng.normal(size=400) for j in range(4)})
    own = own_shares(values)
    assert set(own) == {'bias', 'filter'} and len(own['bias']) == 400
    assert abs(np.mean(own['bias']) - 0.95) < 0.01 and abs(np.mean(own['filter']) - 0.95) < 0.01
    # two independent measures: both inside for about 0.95^2 of the traces
    assert abs(np.mean(np.array(own['bias']) == 1.0) - 0.95 ** 2) < 0.05


def test_the_worst_group_is_read_against_the_classes_own():
    # two folds; own traces 0..3; the real trace is worst in bias; the smoother
    # has no own shares, so it is not among the groups judged
    folds = [{'groups': {'bias': 0.5, 'filter': 1.0, 'smoother': 0.0},
              'own_groups': {'bias': [1.0, 0.5, 1.0, 1.0], 'filter': [1.0, 1.0, 0.5, 1.0]}},
             {'groups': {'bias': 0.5, 'filter': 1.0, 'smoother': 0.0},
              'own_groups': {'bias': [1.0, 0.5, 1.0, 0.5], 'filter': [1.0, 1.0, 1.0, 1.0]}}]
    got = own_verdict(folds)
    assert got['groups'] == ['bias', 'filter']
    # own worst per trace (mean over folds, smallest group): 1.0, 0.5, 0.75, 0.75
    assert got['worst'] == 0.5 and got['own_worst_median'] == 0.75
    assert got['percentile'] == 25.0                 # one own set as low as the real 0.5
    assert got['own_meet_bar'] == 25.0               # only trace 0 has every group >= 0.90
    assert own_verdict([{'groups': {'bias': 1.0}}]) is None


def test_score_differences_tell_a_real_gap_from_the_samples_spread():
    rng = np.random.default_rng(3)
    n = 3000
    # persistent per-sample log densities, as one-step scores of a persistent error are
    shared = np.convolve(rng.normal(0, 1, n + 19), np.ones(20) / 20 ** 0.5, 'valid')
    noise = rng.normal(0, 0.3, n)
    lls = {'pop': shared, 'worse': shared - 0.25 + noise, 'same': shared + noise}
    d = score_differences(lls, 'pop', seed=1)
    assert d['pop'] == {'mean': 0.0, 'ci95': [0.0, 0.0]}
    lo, hi = d['worse']['ci95']
    assert d['worse']['mean'] == pytest.approx(0.25 - noise.mean()) and 0.0 < lo < 0.25 < hi
    lo, hi = d['same']['ci95']
    assert lo < 0.0 < hi
    # the interval is about 1.96 standard errors of the mean of iid noise each side
    assert 0.5 < (hi - lo) / (2 * 1.96 * 0.3 / n ** 0.5) < 2.0
    with pytest.raises(ValueError, match='expected the same samples'):
        score_differences({'pop': shared, 'short': shared[:-1]}, 'pop')


def test_where_a_class_beats_the_population_is_told_by_the_held_out_level():
    """
    A class that wins only where the held-out error sits far from the population's mean.

    600 samples: the first 300 at the population's mean, the last 300 three
    bias SDs out, where the rival's score is 0.5 nats better per sample;
    elsewhere the two tie up to noise.
    """
    rng = np.random.default_rng(5)
    n, sd = 600, np.array([0.5, 1.0])
    err = rng.normal(0.0, 0.1, (n, 2))
    err[300:, 0] += 3 * sd[0]
    pop = rng.normal(-1.0, 0.3, n)
    rival = pop + rng.normal(0.0, 0.05, n)
    rival[300:] += 0.5
    lls = {'population': pop, 'rival': rival, 'worse': pop - 1.0}
    got = where_beaten(lls, score_differences(lls, 'population'), 'population',
                       err, np.arange(n, dtype=float), [0.0, 0.0], sd, block=150)
    assert got['winners'] == ['rival']
    assert [b['samples'] for b in got['blocks']] == [150] * 4
    assert [b['level_sd'] > FAR_SD for b in got['blocks']] == [False, False, True, True]
    assert got['far']['samples'] == got['near']['samples'] == 300
    lo, hi = got['far']['rival']['ci95']
    assert got['far']['rival']['mean'] == pytest.approx(-0.5, abs=0.02) and hi < 0.0
    lo, hi = got['near']['rival']['ci95']
    assert lo < 0.0 < hi
    # no class better beyond its interval: nothing to show
    lls = {'population': pop, 'worse': pop - 1.0}
    assert where_beaten(lls, score_differences(lls, 'population'), 'population', err,
                        np.arange(n, dtype=float), [0.0, 0.0], sd) is None
    lls = {'population': pop, 'rival': rival}
    with pytest.raises(ValueError, match=r'expected \(600, 2\)'):
        where_beaten(lls, score_differences(lls, 'population'), 'population', err[:10],
                     np.arange(n, dtype=float), [0.0, 0.0], sd)


def _ar3(rng, n):
    x = np.zeros(n + 100)
    w = rng.normal(0, 1, n + 100)
    for k in range(3, n + 100):
        x[k] = 0.3 * x[k - 1] + 0.2 * x[k - 2] + 0.35 * x[k - 3] + w[k]
    return x[100:]


def test_the_blocks_choose_the_lags_that_hold_across_them_not_one_stretchs():
    """AR(3) in every block: order 3; in one block of six only: the others say AR(1)."""
    rng = np.random.default_rng(5)
    n = 1800                                            # six blocks of 300 s
    t = np.arange(float(n))
    every = np.stack([_ar3(rng, n), rng.normal(0, 1, n)], axis=1)
    got = block_orders(Part([every[:1000], every[1000:]], [None, None], [t[:1000], t[1000:]]))
    assert got['blocks'] == 6
    assert got['north']['order'] == 3 and got['north']['gain_per_sample'] > 0.05, got
    assert got['east'] == {'order': 1, 'gain_per_sample': 0.0}, got
    one = rng.normal(0, 1, (n, 2))
    one[:300, 0] = _ar3(rng, 300)                       # one stretch's dynamics
    got = block_orders(Part([one], [None], [t]))
    assert got['north']['order'] == 1, got         # (so on seeds 5-14; argmin alone took 6 once)
    # blocks of fewer than 60 samples do not count: three blocks' worth is needed
    sparse = Part([every[:300], every[600:660], every[1200:1259]], [None] * 3,
                  [t[:300], t[600:660], t[1200:1259]])
    assert block_orders(sparse) is None
    assert block_orders(Part([every[:900]], [None], [t[:900]]))['blocks'] == 3


def test_the_partial_autocorrelation_of_a_part_finds_the_lags_it_has():
    """An AR(3) axis beside a white one: lags 1-3 beyond the bound on the first only."""
    rng = np.random.default_rng(2)
    n = 4000
    x = np.zeros(n + 100)
    w = rng.normal(0, 1, n + 100)
    for k in range(3, n + 100):
        x[k] = 0.3 * x[k - 1] + 0.2 * x[k - 2] + 0.35 * x[k - 3] + w[k]
    err = np.stack([x[100:], rng.normal(0, 1, n)], axis=1)
    got = part_pacf(Part([err[:2000], err[2000:]], [None, None],
                         [np.arange(2000.0), np.arange(2000.0)]))
    assert got['bound'] == pytest.approx(1.96 / n ** 0.5, rel=1e-3)
    assert len(got['north']) == 10
    assert [abs(v) > got['bound'] for v in got['north'][:3]] == [True] * 3
    assert got['north'][2] == pytest.approx(0.35, abs=0.05)
    assert sum(abs(v) > got['bound'] for v in got['east']) <= 2
    short = part_pacf(Part([err[:30]], [None], [np.arange(30.0)]))
    assert short is not None and len(short['north']) == 6
    assert part_pacf(Part([err[:15]], [None], [np.arange(15.0)])) is None
    still = err[:100].copy()
    still[:, 1] = 2.0                   # one axis constant: no PACF, and no error
    assert part_pacf(Part([still], [None], [np.arange(100.0)])) is None


def test_a_lag_never_reaches_back_into_the_recording_before():
    """Two recordings 2.5 km apart, joined: the held-out one's first offset and heading."""
    from gps_error_ros.fit.holdout import motion_offsets, travel_headings

    a, b = _trace('a', 400, 1), _trace('b', 400, 2, place=31)
    joined = join_recordings([a, b])
    cut = float(joined.t[-len(b.t)])
    split = split_between(joined, cut, float(joined.t[-1]) + 1.0, 'train a, hold out b')
    first = float(split.test.t[0][0])
    assert first == cut
    offsets = np.concatenate(motion_offsets(split.test, split.truth, 0.5))
    # walking north at 1.1 m/s: half a second back is 0.55 m south, never 12 m west
    assert np.abs(offsets[0]).max() < 1e-9
    assert offsets[5] == pytest.approx([-0.55, 0.0], abs=0.01)
    heading = travel_headings(split.truth, np.array([first, first + 5.0]), 0.5)
    assert heading[1] == pytest.approx(0.0, abs=1e-2)              # north
    assert abs(heading[0]) < 1e-2                # not the jump's west-east direction


def test_the_errors_within_blocks_never_mix_two_runs():
    """Two walks 100 s apart, biases +5 and -5 m: each block's mean is its own walk's."""
    t = [np.arange(450.0), 550.0 + np.arange(450.0)]
    err = [np.full((450, 2), 5.0), np.full((450, 2), -5.0)]
    part = Part(err, [np.zeros((450, 2))] * 2, t)
    out = within_part(part)
    # each walk cut from its own start: blocks of 300 and 150 samples, each about its own mean
    assert [len(e) for e in out.err] == [300, 150, 300, 150]
    assert max(np.abs(e).max() for e in out.err) == 0.0
    np.testing.assert_array_equal(np.concatenate(out.t), np.concatenate(t))

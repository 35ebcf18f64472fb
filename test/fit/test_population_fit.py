"""The population fit recovers the bias spread, its time constant and the scale spread."""

from dataclasses import replace

import numpy as np
import pytest
import yaml

from gps_error_ros.fit.population_bias import (_tau, block_mean_correlation, FLOOR_R,
                                               independent_draws, predictive,
                                               variance_predictive, wander_contrasts)
from gps_error_ros.fit.population_fit import (Block, blocks_of, fit_population, MIN_BLOCKS,
                                              population_line)
from gps_error_ros.model import streams
from gps_error_ros.model.profiles import builtin_dir, profile_from_dict


def _model(section):
    """Return a phone-like process (AR(1), phi 0.9: a 300 s mean's SD 0.6 m) with ``section``."""
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['axes'] = {ax: {'delta': 0.1, 'phi': [0.9], 'sigma_w': 1.0} for ax in ('north', 'east')}
    raw['population'] = section
    return profile_from_dict(raw, 'test').model()


def _runs(model, runs, steps, seed=1):
    """Return (segments, times): each agent one run, the runs one after another."""
    keys = streams.agent_keys(seed, [f'run{i}' for i in range(runs)])
    x = model.simulate(keys, steps)
    segs = [x[:, i] for i in range(runs)]
    times = [i * (steps + 600.0) + np.arange(steps, dtype=float) for i in range(runs)]
    return segs, times


def test_several_runs_give_back_the_bias_spread_and_a_constant_bias():
    model = _model({'bias_sd_m': [3.0, 1.5], 'scale_sd_log': 0.0})
    segs, times = _runs(model, 60, 900)
    fit = fit_population(segs, times)
    pop = fit.population
    # 60 runs: the SD of an SD estimate is about 9 %; the within fit adds a little
    np.testing.assert_allclose(pop.bias_sd_m, [3.0, 1.5], rtol=0.25)
    assert pop.bias_time_constant_s is None, pop
    assert pop.scale_sd_log < 0.15
    # the within process: the phone's persistence, not the runs' biases
    assert abs(sum(fit.north.phi) - 0.9) < 0.03 and abs(fit.north.sigma_w - 1.0) < 0.03


def test_one_long_recording_gives_back_a_wandering_bias():
    model = _model({'bias_sd_m': [3.0, 3.0], 'scale_sd_log': 0.0,
                    'bias_time_constant_s': 1200.0})
    segs, times = _runs(model, 1, 72000, seed=4)
    pop = fit_population(segs, times).population
    assert pop.bias_time_constant_s is not None
    assert 600.0 < pop.bias_time_constant_s < 2400.0, pop
    np.testing.assert_allclose(pop.bias_sd_m, [3.0, 3.0], rtol=0.35)


def test_a_wander_slower_than_the_blocks_is_fitted_with_its_interval():
    """One recording of 20 h, a wander of 400 s: the estimate and its 95 % interval hold it."""
    model = _model({'bias_sd_m': [3.0, 3.0], 'scale_sd_log': 0.0,
                    'bias_time_constant_s': 400.0})
    fit = fit_population(*_runs(model, 1, 72000, seed=5))
    tc = fit.evidence['bias_time_constant']
    assert tc['kind'] == 'estimate' and tc['value_s'] == tc['estimate_s'], tc
    assert 400.0 * 0.7 < fit.population.bias_time_constant_s < 400.0 * 1.4, tc
    assert tc['interval_95_s'][0] < 400.0 < tc['interval_95_s'][1], tc
    assert 'a time constant of' in population_line(fit) and 'interval' in population_line(fit)


def test_a_wander_faster_than_the_blocks_is_stated_as_a_bound():
    """A wander of 60 s: blocks of 300 s cannot fit it; the profile says it is a bound."""
    model = _model({'bias_sd_m': [3.0, 3.0], 'scale_sd_log': 0.0,
                    'bias_time_constant_s': 60.0})
    fit = fit_population(*_runs(model, 1, 36000, seed=4))
    tc = fit.evidence['bias_time_constant']
    floor = _tau(FLOOR_R, 300.0)
    assert tc['kind'] == 'upper bound' and tc['value_s'] == round(floor, 1), tc
    assert fit.population.bias_time_constant_s == floor
    assert tc['estimate_s'] < floor and tc['interval_95_s'][1] < floor, tc
    line = population_line(fit)
    assert f'at most {tc["value_s"]:.0f} s (a bound, not a fit' in line, line


@pytest.mark.parametrize('tau', [30.0, 150.0, 300.0, 1000.0, 5000.0])
def test_block_means_correlate_as_the_discrete_wander_gives(tau):
    """The formula against the exact sum for a wander stepped each second (blocks of 300)."""
    n, a = 300, np.exp(-1.0 / tau)
    k = np.arange(1, n)
    var = n + 2.0 * np.sum((n - k) * a ** k)
    cov = a * (1.0 - a ** n) ** 2 / (1.0 - a) ** 2
    assert block_mean_correlation(n / tau) == pytest.approx(cov / var, rel=0.01, abs=1e-3)
    assert _tau(block_mean_correlation(n / tau), n) == pytest.approx(tau, rel=1e-9)


def test_runs_whose_bias_has_a_held_and_a_wandering_part_give_back_both():
    """40 runs of 1500 s: a part held for each run (3 m north, 0.5 m east) and a wander."""
    model = _model({'bias_sd_m': [1.5, 1.5], 'scale_sd_log': 0.0,
                    'bias_time_constant_s': 400.0, 'run_bias_sd_m': [3.0, 0.5]})
    fit = fit_population(*_runs(model, 40, 1500, seed=3))
    pop = fit.population
    assert pop.run_bias_sd_m is not None, fit.evidence
    # 40 draws of the held part: its SD known to about 11 %; the east part is small
    np.testing.assert_allclose(pop.run_bias_sd_m[0], 3.0, rtol=0.3)
    assert pop.run_bias_sd_m[1] < 1.5
    np.testing.assert_allclose(pop.bias_sd_m, [1.5, 1.5], rtol=0.35)
    # a fit, not a bound, and on both sides of the truth (the held part muddles it a little)
    assert fit.evidence['bias_time_constant']['kind'] == 'estimate', fit.evidence
    assert 250.0 < pop.bias_time_constant_s < 800.0, pop
    assert fit.evidence['independent_draws'] == 40
    # the evidence: the runs' means spread by about the held part, the blocks within by the wander
    assert fit.evidence['run_means_sd_m'][0] > fit.evidence['block_means_within_run_sd_m'][0]
    assert 'a part held for the run, SD' in population_line(fit)
    # asked for one part, the same runs give the one-part fit
    one = fit_population(*_runs(model, 40, 1500, seed=3), two_scales=False).population
    assert one.run_bias_sd_m is None
    np.testing.assert_allclose(np.square(one.bias_sd_m),
                               np.square(pop.bias_sd_m) + np.square(pop.run_bias_sd_m),
                               rtol=0.5)


def test_one_recording_cannot_tell_a_held_part_from_the_wander():
    model = _model({'bias_sd_m': [2.0, 2.0], 'scale_sd_log': 0.0,
                    'bias_time_constant_s': 600.0, 'run_bias_sd_m': [3.0, 3.0]})
    pop = fit_population(*_runs(model, 1, 7200, seed=8)).population
    assert pop.run_bias_sd_m is None and pop.bias_time_constant_s is not None, pop


def test_phones_that_differ_in_scale_give_back_the_scale_spread():
    model = _model({'bias_sd_m': [0.5, 0.5], 'scale_sd_log': 0.4})
    segs, times = _runs(model, 80, 900, seed=7)
    pop = fit_population(segs, times).population
    assert 0.25 < pop.scale_sd_log < 0.55, pop


def test_too_few_blocks_fit_no_population_and_say_why():
    model = _model({'bias_sd_m': [1.0, 1.0], 'scale_sd_log': 0.0})
    segs, times = _runs(model, 1, 500)
    fit = fit_population(segs, times)
    assert fit.population is None
    assert fit.evidence['fitted'] is False
    assert f'needs {MIN_BLOCKS}' in fit.evidence['reason']
    assert len(fit.axis_params()) == 2


def test_an_occasion_recorded_by_many_receivers_counts_once():
    """
    Twelve runs, each with its own bias (SD 3 m); the first recorded by twelve receivers.

    Counted per recording, that run's bias is 12 of 23 draws and pulls the
    mean to it and the spread down; weighed 1/12 each, it is one draw.
    """
    rng = np.random.default_rng(5)
    plain = _model({'bias_sd_m': [1e-6, 1e-6], 'scale_sd_log': 0.0})
    biases = np.array([[9.0, -9.0]] + [list(rng.normal(0.0, 3.0, 2)) for _ in range(11)])
    receivers = [12] + [1] * 11
    segs, times, weights, start = [], [], [], 0.0
    for run, (bias, k) in enumerate(zip(biases, receivers)):
        keys = streams.agent_keys(run, [f'r{i}' for i in range(k)])
        x = plain.simulate(keys, 900)
        for i in range(k):
            segs.append(x[:, i] + bias)
            times.append(start + np.arange(900, dtype=float))
            weights.append(1.0 / k)
            start += 1500.0
    counted = fit_population(segs, times)
    weighed = fit_population(segs, times, weights=weights)
    assert weighed.evidence['weighted_blocks'] == 12 * 3
    # the first run's bias is 3 SD out: counted twelve times it drags the mean
    # halfway to it; weighed once it moves the mean by about 1/12 of it
    mean = plain.mean                   # the process's own mean, 1 m per axis
    np.testing.assert_allclose(counted.mean, mean + (12 * biases[0] + biases[1:].sum(0)) / 23,
                               atol=0.3)
    np.testing.assert_allclose(weighed.mean, mean + biases.mean(axis=0), atol=0.3)
    spread = biases.std(axis=0, ddof=1)
    np.testing.assert_allclose(weighed.evidence['bias_sd_estimate_m'], spread, rtol=0.1)
    # twelve draws: a new run's bias is t(11), its SD the estimate's x 1.15
    assert weighed.evidence['independent_draws'] == 12.0
    assert weighed.population.bias_dof == 11


def test_the_walks_of_one_occasion_are_found_from_their_truths():
    """w03-w05: three receivers carried on one walk; the GSDC phones: one car, one drive."""
    from gps_error_ros.fit.population_fit import occasions
    from gps_error_ros.traces.trace_io import read_trace_csv
    from measured import DATA as data
    walks = [read_trace_csv(p) for p in sorted(data.glob('snapper-walk-w0*.csv'))]
    assert [w.name[-7:-4] for w in walks] == [f'w0{i}' for i in range(7)]
    assert occasions(walks) == [0, 1, 2, 3, 3, 3, 4]
    phones = [read_trace_csv(data / f'gsdc2020-mtv1-{p}.csv')
              for p in ('pixel4', 'pixel4xlmodded')]
    assert occasions(phones) == [0, 0]
    assert occasions([walks[0], phones[0]]) == [0, 1]
    # a standing receiver's truth says nothing of when: two static logs stay two occasions
    standing = [replace(walks[0], truth_lat=np.full(len(walks[0]), 51.76),
                        truth_lon=np.full(len(walks[0]), -1.257)) for _ in range(2)]
    assert occasions(standing) == [0, 1]


def _chain(t0, m, weight=1.0):
    """Return ``m`` neighbouring blocks of 300 s from ``t0``."""
    return [Block(np.zeros((300, 2)), t0 + 300.0 * j, t0 + 300.0 * j + 299.0, weight)
            for j in range(m)]


def test_a_new_occasions_bias_is_predicted_from_the_independent_draws():
    three_runs = _chain(0.0, 3) + _chain(5000.0, 3) + _chain(9000.0, 3)
    assert independent_draws(three_runs) == 3.0              # a constant bias per run
    assert independent_draws(three_runs, r=0.0) == 9.0       # blocks independent
    # a wandering bias: four neighbours correlated 0.86 are worth 1.19 draws
    assert abs(independent_draws(_chain(0.0, 4), r=0.86) - 1.195) < 0.01
    # three receivers on one walk (weight 1/3 each) are one draw
    shared = _chain(0.0, 2, 1 / 3) + _chain(2000.0, 2, 1 / 3) + _chain(4000.0, 2, 1 / 3)
    assert abs(independent_draws(shared) - 1.0) < 1e-12
    # Student-t with k - 1 degrees of freedom (rounded, at least 3),
    # scale s sqrt(1 + 1/k): the factor on s is the SD of that law
    dof, factor = predictive(5.27)
    assert dof == 4 and abs(factor - np.sqrt(1 + 1 / 5.27) * np.sqrt(2.0)) < 1e-12
    assert predictive(2.0)[0] == 3
    dof, factor = predictive(100.0)
    assert dof is None and abs(factor - np.sqrt(1.01)) < 1e-12


def test_a_population_of_few_runs_is_written_wide_and_heavy_tailed():
    model = _model({'bias_sd_m': [3.0, 3.0], 'scale_sd_log': 0.0})
    segs, times = _runs(model, 6, 900, seed=2)
    fit = fit_population(segs, times)
    pop, ev = fit.population, fit.evidence
    assert ev['independent_draws'] == 6.0 and pop.bias_dof == 5
    factor = np.sqrt(1 + 1 / 6) * np.sqrt(5 / 3)
    np.testing.assert_allclose(pop.bias_sd_m, np.array(ev['bias_sd_estimate_m']) * factor,
                               rtol=1e-3)


def test_the_wander_of_few_runs_is_predicted_from_its_contrasts():
    """Four runs of three blocks: 8 contrasts within runs, the wander's SD times sqrt(8 / 6)."""
    model = _model({'bias_sd_m': [1.5, 1.5], 'scale_sd_log': 0.0,
                    'bias_time_constant_s': 400.0, 'run_bias_sd_m': [3.0, 0.5]})
    fit = fit_population(*_runs(model, 4, 900, seed=1))
    pop, ev = fit.population, fit.evidence
    assert pop.run_bias_sd_m is not None, ev
    assert ev['wander_contrasts'] == 8.0
    np.testing.assert_allclose(pop.bias_sd_m, np.array(ev['wander_sd_estimate_m']) *
                               np.sqrt(8 / 6), rtol=1e-3)
    assert 'predicted from 8.0 contrasts of blocks within runs' in population_line(fit)
    # a chain of m blocks holds m - 1 contrasts, counted by its weight
    shared = _chain(0.0, 4, 1 / 3) + _chain(2000.0, 4, 1 / 3) + _chain(4000.0, 1)
    assert abs(wander_contrasts(shared) - 2.0) < 1e-12
    # Student-t's SD over its scale, at least 3 degrees of freedom, 1 beyond 30
    assert variance_predictive(1.2) == np.sqrt(3.0)
    assert abs(variance_predictive(6.4) - np.sqrt(6 / 4)) < 1e-12
    assert variance_predictive(31.0) == 1.0


def test_no_block_holds_samples_of_two_recordings():
    # two recordings of 450 s joined 100 s apart: each is cut from its own start
    first = np.arange(450, dtype=float)
    second = first[-1] + 100.0 + np.arange(450, dtype=float)
    segs = [np.zeros((450, 2)), np.ones((450, 2))]
    blocks = blocks_of(segs, [first, second])
    assert [(b.t0, b.t1) for b in blocks] == [(0.0, 299.0), (300.0, 449.0),
                                              (549.0, 848.0), (849.0, 998.0)]
    assert [float(b.err.mean()) for b in blocks] == [0.0, 0.0, 1.0, 1.0]
    assert independent_draws(blocks) == 2.0

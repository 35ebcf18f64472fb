"""The population section: its schema, its draws, its moments and the model that carries it."""

import numpy as np
import pytest
import yaml

from gps_error_ros.model import streams
from gps_error_ros.model.population import population_from_dict, WithPopulation
from gps_error_ros.model.profiles import (builtin_dir, load_profile, profile_from_dict,
                                          ProfileError)

SECTION = {'bias_sd_m': [2.0, 3.0], 'scale_sd_log': 0.3}
WANDER = dict(SECTION, bias_time_constant_s=200.0)
HEAVY = dict(WANDER, bias_dof=4)
TWO = dict(HEAVY, run_bias_sd_m=[1.5, 4.0])


def _profile(section=SECTION, base='DS5', **extra):
    raw = yaml.safe_load((builtin_dir() / f'{base}.yaml').read_text())
    raw['population'] = section
    raw.update(extra)
    return profile_from_dict(raw, 'test')


def test_a_profile_without_the_section_is_unchanged_bit_for_bit():
    keys = streams.agent_keys(3, ['a', 'b', 'c'])
    plain = load_profile('DS5').model().simulate(keys, 300)
    section = _profile({'bias_sd_m': [0.0, 0.0], 'scale_sd_log': 0.0}).model()
    assert isinstance(section, WithPopulation)
    np.testing.assert_allclose(section.simulate(keys, 300), plain, atol=1e-12, rtol=0)
    assert not isinstance(load_profile('DS5').model(), WithPopulation)


def test_each_agent_draws_its_own_bias_and_scale_from_the_stated_laws():
    model = _profile().model()
    inner = load_profile('DS5').model()
    keys = streams.agent_keys(11, [f'p{i}' for i in range(3000)])
    x = model.simulate(keys, 40)
    plain = inner.simulate(keys, 40)
    m = inner.mean
    bias = x.mean(axis=0) - m - (plain.mean(axis=0) - m) * \
        np.exp(0.3 * streams.normal_pairs(keys, streams.DOMAIN_POPULATION_SCALE, 0)[:, :1] - 0.09)
    sd = bias.std(axis=0)
    # 3000 draws: the SD of an SD estimate is about sd / sqrt(2 n) = 1.3 %
    np.testing.assert_allclose(sd, [2.0, 3.0], rtol=0.06)
    dev = (x - x.mean(axis=0))
    dev_plain = (plain - plain.mean(axis=0))
    ratio = np.sqrt((dev ** 2).sum(axis=(0, 2)) / (dev_plain ** 2).sum(axis=(0, 2)))
    # f = exp(0.3 z - 0.09): log f has SD 0.3 and mean -0.09
    assert abs(np.log(ratio).std() - 0.3) < 0.03 and abs(np.log(ratio).mean() + 0.09) < 0.03
    # normalised: the mean of f^2 is 1
    assert abs(np.mean(ratio ** 2) - 1.0) < 0.05


def test_the_stationary_covariance_covers_the_population():
    model = _profile(WANDER).model()
    inner = load_profile('DS5').model()
    np.testing.assert_allclose(model.stationary_cov,
                               inner.stationary_cov + np.diag([4.0, 9.0]), rtol=1e-12)
    keys = streams.agent_keys(2, [f'q{i}' for i in range(4000)])
    x = model.simulate(keys, 3, start=50)[-1]
    emp = np.cov(x.T)
    np.testing.assert_allclose(np.diag(emp), np.diag(model.stationary_cov), rtol=0.08)
    acv = model.autocovariance(100)
    np.testing.assert_allclose(acv[100], inner.autocovariance(100)[100] +
                               np.exp(-0.5) * np.diag([4.0, 9.0]), rtol=1e-12)


def test_a_wandering_bias_has_its_time_constant():
    prof = _profile({'bias_sd_m': [2.0, 2.0], 'scale_sd_log': 0.0,
                     'bias_time_constant_s': 50.0})
    model = prof.model()
    keys = streams.agent_keys(4, [f'w{i}' for i in range(400)])
    x = model.simulate(keys, 2000)
    plain = load_profile('DS5').model().simulate(keys, 2000)
    b = x - plain                                  # the bias alone (scale 1)
    lag = 50
    r = np.mean(b[lag:] * b[:-lag]) / np.mean(b * b)
    assert abs(r - np.exp(-1.0)) < 0.06, r
    assert abs(b.std() - 2.0) < 0.1


@pytest.mark.parametrize('section', [WANDER, HEAVY, TWO],
                         ids=['normal', 'student-t', 'two time scales'])
def test_every_path_gives_the_same_errors(section):
    """simulate, stepping, state_after, a late start, alone or with others: one function."""
    model = _profile(section).model()
    keys = streams.agent_keys(9, ['x', 'y', 'z'])
    whole = model.simulate(keys, 60, start=100)
    state = model.initial_state(keys, 100)
    stepped = [model.errors(state)]
    for k in range(101, 160):
        stepped.append(model.advance(state, keys, k))
        np.testing.assert_array_equal(model.errors(state), stepped[-1])
    np.testing.assert_allclose(np.array(stepped), whole, atol=1e-9, rtol=0)
    later = model.state_after(keys, 100, 130)
    np.testing.assert_allclose(model.errors(later), whole[30], atol=1e-9, rtol=0)
    alone = model.simulate(keys[1:2], 60, start=100)
    np.testing.assert_array_equal(alone[:, 0], whole[:, 1])


def test_a_bias_on_two_time_scales_holds_one_part_for_the_run():
    """``run_bias_sd_m``: a part drawn at the start and held, beside the wandering part."""
    section = dict(WANDER, scale_sd_log=0.0, run_bias_sd_m=[1.5, 4.0])
    model = _profile(section).model()
    inner = load_profile('DS5').model()
    held = np.diag([2.25, 16.0])
    np.testing.assert_allclose(model.stationary_cov,
                               inner.stationary_cov + np.diag([4.0, 9.0]) + held, rtol=1e-12)
    np.testing.assert_allclose(model.autocovariance(400)[400], inner.autocovariance(400)[400]
                               + np.exp(-2.0) * np.diag([4.0, 9.0]) + held, rtol=1e-12)
    keys = streams.agent_keys(6, [f'h{i}' for i in range(2000)])
    b = model.simulate(keys, 1200) - inner.simulate(keys, 1200)    # the bias alone
    # the part held: what the run's bias keeps from its first step to its last
    start, end = b[:50].mean(axis=0), b[-50:].mean(axis=0)
    shared = np.mean(start * end, axis=0)
    # 2000 runs: each product's SD is about var, so the mean's is 2-3 %
    np.testing.assert_allclose(shared, [2.25, 16.0], rtol=0.15)
    np.testing.assert_allclose(b.std(axis=(0, 1)), np.sqrt([6.25, 25.0]), rtol=0.05)
    # the same wander as without the part: the step-to-step changes
    plain = _profile(dict(WANDER, scale_sd_log=0.0)).model().simulate(keys, 1200) - \
        inner.simulate(keys, 1200)
    np.testing.assert_allclose(np.diff(b, axis=0), np.diff(plain, axis=0), atol=1e-9)
    # given the state, the next error: the held part known, its innovations of unit variance
    before = model.state_after(keys, 0, 30)
    pm, cov = model.predictive_mean(before), model.predictive_cov(before)
    step = model.advance(before.copy(), keys, 31)
    z = np.linalg.solve(np.linalg.cholesky(cov), (step - pm)[..., None])[..., 0]
    assert 0.85 < np.mean(z ** 2) < 1.15, np.mean(z ** 2)


def test_the_conditional_covariance_knows_the_agent():
    model = _profile(WANDER).model()
    inner = load_profile('DS5').model()
    keys = streams.agent_keys(5, ['a', 'b'])
    state = model.state_after(keys, 0, 20)
    f = state.scale
    a2 = np.exp(-2.0 / 200.0)
    want = inner.predictive_cov(state.inner) * (f ** 2)[:, None, None] + \
        np.diag([4.0, 9.0]) * (1 - a2)
    np.testing.assert_allclose(model.predictive_cov(state), want, rtol=1e-12)
    first = model.predictive_cov(model.initial_state(keys, 0), first=True)
    np.testing.assert_allclose(first[0], inner.predictive_cov(state.inner, first=True)[0]
                               + np.diag([4.0, 9.0]), rtol=1e-12)
    # the expected next error: what the next step's error is, up to its innovation
    nxt = state.copy()
    err = model.advance(nxt, keys, 21)
    mean = model.predictive_mean(state)
    cov = model.predictive_cov(state)
    z = np.linalg.solve(np.linalg.cholesky(cov), (err - mean)[..., None])[..., 0]
    assert np.all(np.abs(z) < 6)


def test_the_section_round_trips_and_wraps_inside_failures():
    prof = _profile(TWO, gross_failures={'rate': 0.01, 'sizes_m': [100.0]})
    model = prof.model()
    assert type(model).__name__ == 'WithFailures'
    assert isinstance(model.inner, WithPopulation)
    assert population_from_dict(prof.population.to_dict()) == prof.population


@pytest.mark.parametrize('bad, says', [
    ({'bias_sd_m': [1.0, 1.0]}, "['bias_sd_m', 'scale_sd_log']"),
    ({'bias_sd_m': [1.0], 'scale_sd_log': 0.1}, 'two numbers'),
    ({'bias_sd_m': [1.0, -1.0], 'scale_sd_log': 0.1}, 'two numbers'),
    ({'bias_sd_m': [1.0, float('nan')], 'scale_sd_log': 0.1}, 'two numbers'),
    ({'bias_sd_m': [1.0, 1.0], 'scale_sd_log': 3.0}, '[0, 2]'),
    ({'bias_sd_m': [1.0, 1.0], 'scale_sd_log': 0.1, 'bias_time_constant_s': 0}, '(0, 1e9]'),
    ({'bias_sd_m': [1.0, 1.0], 'scale_sd_log': 0.1, 'other': 1}, 'optionally'),
    ({'bias_sd_m': [1.0, 1.0], 'scale_sd_log': 0.1, 'bias_dof': 2}, '[3, 30]'),
    ({'bias_sd_m': [1.0, 1.0], 'scale_sd_log': 0.1, 'bias_dof': 4.5}, '[3, 30]'),
    ({'bias_sd_m': [1.0, 1.0], 'scale_sd_log': 0.1, 'run_bias_sd_m': [1.0]},
     'run_bias_sd_m: expected two numbers'),
])
def test_a_bad_section_is_refused_with_what_was_expected(bad, says):
    with pytest.raises(ProfileError) as err:
        _profile(bad)
    assert 'population' in str(err.value) and says in str(err.value)


def test_a_student_t_bias_keeps_its_sd_and_has_heavy_tails():
    keys = streams.agent_keys(6, [f't{i}' for i in range(20000)])
    section = {'bias_sd_m': [2.0, 2.0], 'scale_sd_log': 0.0}
    normal = _profile(section).model().simulate(keys, 1)[0]
    heavy = _profile(dict(section, bias_dof=4)).model().simulate(keys, 1)[0]
    plain = load_profile('DS5').model().simulate(keys, 1)[0]
    for x in (normal, heavy):
        b = (x - plain).ravel()                    # the bias alone (scale 1)
        # the SD stated, 2 m: t(4)'s SD estimate varies more than a normal's
        assert abs(b.std() - 2.0) < 0.12, b.std()
    beyond = [np.mean(np.abs(x - plain) > 6.0) for x in (normal, heavy)]
    # beyond 3 SD: 0.27 % of normal draws; 1.3 % of t(4) draws of that SD
    assert beyond[0] < 0.005 and 0.008 < beyond[1] < 0.02, beyond
    # the same normal draws under the factor: one stream, a different law
    g = (heavy - plain) / (normal - plain)
    np.testing.assert_allclose(g[:, 0], g[:, 1], rtol=1e-9)


def test_the_conditional_covariance_knows_a_student_t_runs_factor():
    model = _profile(HEAVY).model()
    inner = load_profile('DS5').model()
    keys = streams.agent_keys(5, ['a', 'b', 'c'])
    state = model.state_after(keys, 0, 20)
    f, g = state.scale, state.bias_factor
    assert np.all(g > 0) and not np.allclose(g, 1.0)
    a2 = np.exp(-2.0 / 200.0)
    want = inner.predictive_cov(state.inner) * (f ** 2)[:, None, None] + \
        np.diag([4.0, 9.0]) * (1 - a2) * (g ** 2)[:, None, None]
    np.testing.assert_allclose(model.predictive_cov(state), want, rtol=1e-12)
    np.testing.assert_allclose(model.stationary_cov,
                               inner.stationary_cov + np.diag([4.0, 9.0]), rtol=1e-12)

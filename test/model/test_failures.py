"""The gross_failures section: its schema, its draws, and the model that carries it."""

import numpy as np
import pytest
import yaml

from gps_error_ros.model import streams
from gps_error_ros.model.failures import (failures_from_dict, failures_from_sizes,
                                          GrossFailureProcess, WithFailures)
from gps_error_ros.model.profiles import (builtin_dir, load_profile, profile_from_dict,
                                          ProfileError)

SECTION = {'rate': 0.05, 'sizes_m': [50.0, 300.0, 20000.0]}


def _profile(section=SECTION, base='DS5'):
    raw = yaml.safe_load((builtin_dir() / f'{base}.yaml').read_text())
    raw['gross_failures'] = section
    return profile_from_dict(raw, 'test')


def test_a_profile_without_the_section_is_unchanged_bit_for_bit():
    keys = streams.agent_keys(3, ['a', 'b', 'c'])
    plain = load_profile('DS5').model().simulate(keys, 500)
    with_section = _profile().model(gross_failures=False).simulate(keys, 500)
    np.testing.assert_array_equal(plain, with_section)


def test_failures_replace_the_error_and_leave_the_process_running():
    keys = streams.agent_keys(5, [f'agent{i}' for i in range(40)])
    plain = load_profile('DS5').model().simulate(keys, 2000)
    model = _profile().model()
    assert isinstance(model, WithFailures)
    failed = model.simulate(keys, 2000)
    differs = np.any(failed != plain, axis=2)
    rate = differs.mean()
    assert abs(rate - 0.05) < 4 * np.sqrt(0.05 * 0.95 / differs.size), rate
    size = np.hypot(*failed[differs].T)
    assert size.min() >= 50.0 - 1e-9 and size.max() <= 20000.0 + 1e-6
    # interpolated in the log of the size: half lie below the middle quantile,
    # a quarter below its geometric mean with the smallest
    for below, share in ((300.0, 0.5), (np.sqrt(50.0 * 300.0), 0.25)):
        assert abs(np.mean(size < below) - share) < 4 * np.sqrt(share * (1 - share) / size.size)
    # direction uniform: no axis preferred
    north, east = failed[differs].T
    assert abs(np.mean(north / size)) < 0.05 and abs(np.mean(east / size)) < 0.05


@pytest.mark.parametrize('spread', [None, 1.2], ids=['one rate', 'a rate per agent'])
def test_every_path_gives_the_same_failures(spread):
    """simulate, stepping, state_after and a late start agree: a pure function of (key, step)."""
    section = {'rate': 0.2, 'sizes_m': [80.0]}
    if spread is not None:
        section['rate_sd_log'] = spread
    model = _profile(section).model()
    keys = streams.agent_keys(9, ['x', 'y'])
    whole = model.simulate(keys, 60, start=100)
    state = model.initial_state(keys, 100)
    stepped = [model.errors(state)]
    for k in range(101, 160):
        stepped.append(model.advance(state, keys, k))
        np.testing.assert_array_equal(model.errors(state), stepped[-1])
    np.testing.assert_allclose(np.array(stepped), whole, atol=1e-9, rtol=0)
    later = model.state_after(keys, 100, 130)
    np.testing.assert_allclose(model.errors(later), whole[30], atol=1e-9, rtol=0)
    alone = model.simulate(keys[1:], 60, start=100)
    np.testing.assert_array_equal(alone[:, 0], whole[:, 1])
    constant = np.hypot(*whole[np.any(whole != 0, axis=2) & (np.hypot(*whole.T).T > 79)].T)
    assert constant.size and np.allclose(constant, 80.0)


def test_the_covariance_does_not_cover_failures():
    a, b = load_profile('DS5').model(), _profile().model()
    np.testing.assert_array_equal(a.stationary_cov, b.stationary_cov)
    state = b.initial_state(streams.agent_keys(1, ['a']), 0)
    np.testing.assert_array_equal(b.predictive_cov(state, first=True),
                                  a.predictive_cov(a.initial_state(
                                      streams.agent_keys(1, ['a']), 0), first=True))


@pytest.mark.parametrize('bad, says', [
    ({'rate': 0.1}, "['rate', 'sizes_m']"),
    ({'rate': 1.0, 'sizes_m': [1.0]}, '[0, 1)'),
    ({'rate': 0.1, 'sizes_m': []}, 'non-decreasing'),
    ({'rate': 0.1, 'sizes_m': [5.0, 1.0]}, 'non-decreasing'),
    ({'rate': 0.1, 'sizes_m': [0.0, 1.0]}, 'non-decreasing'),
    ({'rate': 0.1, 'sizes_m': [float('nan')]}, 'non-decreasing'),
    ({'rate': 0.1, 'sizes_m': [1.0], 'rate_sd_log': -0.5}, 'rate_sd_log'),
    ({'rate': 0.1, 'sizes_m': [1.0], 'rate_sd_log': 4.0}, 'rate_sd_log'),
    ({'rate': 0.1, 'sizes_m': [1.0], 'rate_sd_log': float('nan')}, 'rate_sd_log'),
    ({'rate': 0.1, 'sizes_m': [1.0], 'rate_sd_log': True}, 'rate_sd_log'),
    ({'rate': 0.1, 'sizes_m': [1.0], 'rate_spread': 1.0}, 'optionally'),
])
def test_a_bad_section_is_refused_with_its_key(bad, says):
    with pytest.raises(ProfileError, match='gross_failures') as exc:
        _profile(bad)
    assert says in str(exc.value)


def test_fitted_section_from_found_failures():
    assert failures_from_sizes(0, 100, []) is None
    one = failures_from_sizes(1, 400, [96.0])
    assert one == GrossFailureProcess(0.0025, (96.0,))
    many = failures_from_sizes(40, 1000, np.geomspace(40.0, 24000.0, 40))
    assert many.rate == 0.04 and len(many.sizes_m) == 11
    assert many.sizes_m[0] == pytest.approx(40.0) and many.sizes_m[-1] == pytest.approx(24000.0)
    assert failures_from_dict(many.to_dict()).sizes_m == pytest.approx(many.sizes_m, abs=1e-3)


def _counts(section, agents=400, steps=2000, seed=6):
    """Return each agent's number of failures in ``steps`` steps of the section's model."""
    keys = streams.agent_keys(seed, [f'agent{i}' for i in range(agents)])
    process = failures_from_dict(section)
    return np.array([process.offsets(keys, k)[1] for k in range(steps)]).sum(axis=0), process


def test_each_agent_fails_at_a_rate_of_its_own():
    """With rate_sd_log the agents' rates spread log-normally about the section's mean rate."""
    counts, process = _counts({'rate': 0.05, 'sizes_m': [80.0], 'rate_sd_log': 0.8})
    rates = process.agent_rates(streams.agent_keys(6, [f'agent{i}' for i in range(400)]))
    # the agent's count is a draw at its own rate, not at the section's
    assert np.corrcoef(counts, rates)[0, 1] > 0.95
    assert abs(np.mean(rates) / 0.05 - 1.0) < 4 * np.sqrt(np.expm1(0.64) / 400)
    assert abs(np.std(np.log(rates)) - 0.8) < 0.1
    # far more spread than one rate gives: binomial SD at 2000 x 0.05 is 9.7
    assert np.std(counts) > 4 * np.sqrt(2000 * 0.05 * 0.95)
    # the count's law is the one validate uses: its central 95 % holds about 95 % of agents
    lo, hi = process.count_range(2000)
    inside = np.mean((counts >= lo) & (counts <= hi))
    assert abs(inside - 0.95) < 4 * np.sqrt(0.95 * 0.05 / 400), (lo, hi, inside)
    one = failures_from_dict({'rate': 0.05, 'sizes_m': [80.0]})
    lo1, hi1 = one.count_range(2000)
    assert hi - lo > 3 * (hi1 - lo1)


def test_an_agent_keeps_its_rate_whenever_it_starts():
    process = failures_from_dict({'rate': 0.05, 'sizes_m': [80.0], 'rate_sd_log': 1.0})
    keys = streams.agent_keys(2, ['a', 'b', 'c'])
    np.testing.assert_array_equal(process.agent_rates(keys), process.agent_rates(keys[::-1])[::-1])
    early = np.array([process.offsets(keys, k)[1] for k in range(3000)]).sum(axis=0)
    late = np.array([process.offsets(keys, k)[1] for k in range(50000, 53000)]).sum(axis=0)
    assert np.array_equal(np.argsort(early), np.argsort(late))


def test_the_spread_is_fitted_from_the_recordings_counts():
    """Maximum likelihood over recordings: recovers a spread, and finds none where none is."""
    from gps_error_ros.fit.gross_failures import fit_rate_spread
    counts, _ = _counts({'rate': 0.02, 'sizes_m': [80.0], 'rate_sd_log': 1.0},
                        agents=60, steps=1200, seed=8)
    rate, spread = fit_rate_spread(counts, [1200] * 60)
    assert spread is not None and abs(spread - 1.0) < 0.3, spread
    assert abs(np.log(rate / 0.02)) < 0.35, rate
    counts, _ = _counts({'rate': 0.02, 'sizes_m': [80.0]}, agents=60, steps=1200, seed=8)
    assert fit_rate_spread(counts, [1200] * 60) == (counts.sum() / 72000, None)
    # too few recordings to tell receivers apart: the pooled rate alone
    assert fit_rate_spread([1, 57], [300, 1200]) == (58 / 1500, None)
    fitted = failures_from_sizes(58, 1500, [60.0] * 58, spread=(0.03, 0.9))
    assert fitted.rate == 0.03 and fitted.rate_sd_log == 0.9
    back = failures_from_dict(fitted.to_dict())
    assert back.rate_sd_log == 0.9 and back.sizes_m == pytest.approx(fitted.sizes_m)

"""street_frame: innovations along and across the direction of travel."""

import math

import numpy as np
import pytest
import yaml

from gps_error_ros.model import streams
from gps_error_ros.model.effects import effects_from_dict, EffectsError
from gps_error_ros.model.profiles import builtin_dir, profile_from_dict
from gps_error_ros.model.stepping import StepsPerFix
from gps_error_ros.model.zoned import TravelDirections

ALONG, ACROSS = 0.5, 2.0


def street_model(**extra):
    raw = yaml.safe_load((builtin_dir() / 'DS1.yaml').read_text())
    raw['effects'] = {'street_frame': {'sigma_along': ALONG, 'sigma_across': ACROSS}, **extra}
    return profile_from_dict(raw).model()


def test_schema_round_trip_and_conflict():
    eff = effects_from_dict({'street_frame': {'sigma_along': 0.6, 'sigma_across': 1.4}})
    assert eff.names == ('street_frame',) and eff.street == (0.6, 1.4)
    assert effects_from_dict(eff.to_dict()) == eff
    with pytest.raises(EffectsError, match='street_frame and cross_axis_coupling'):
        effects_from_dict({'street_frame': {'sigma_along': 1, 'sigma_across': 2},
                           'cross_axis_coupling': {'innovation_corr': 0.3}})
    with pytest.raises(EffectsError, match=r'effects.street_frame.sigma_across: expected a '
                                           r'number in \(0, 1e6\], got -2'):
        effects_from_dict({'street_frame': {'sigma_along': 1, 'sigma_across': -2}})
    # the stationary covariance: the AR part with the average innovation variance
    m = street_model()
    assert np.allclose(np.diag(m.unit.innovation_cov), 0.5 * (ALONG ** 2 + ACROSS ** 2))


@pytest.mark.parametrize('heading, cov', [
    (0.0, [[ALONG ** 2, 0.0], [0.0, ACROSS ** 2]]),                # north
    (math.pi / 2, [[ACROSS ** 2, 0.0], [0.0, ALONG ** 2]]),        # east
    (math.pi / 4, [[0.5 * (ALONG ** 2 + ACROSS ** 2), 0.5 * (ALONG ** 2 - ACROSS ** 2)],
                   [0.5 * (ALONG ** 2 - ACROSS ** 2), 0.5 * (ALONG ** 2 + ACROSS ** 2)]]),
])
def test_the_innovations_turn_with_the_walker(heading, cov):
    """Innovations of 20,000 agents at one step: their covariance is the turned ellipse."""
    m = street_model()
    n = 20000
    keys = streams.agent_keys(1, [f'a{i}' for i in range(n)])
    zoned = StepsPerFix(m, n, conditional_cov=True)
    zoned.restart(0)
    rows = np.arange(n)
    zoned.errors(rows, keys, 5, None, np.full(n, 1.0))   # any direction
    before = m.carried(zoned.state)
    e, c = zoned.errors(rows, keys, 6, None, np.full(n, heading))
    w = e - m.mean - np.einsum('ai,nai->na', m.phi, before - m.mean[None, :, None])
    got = np.cov(w.T)
    tol = 4 * np.sqrt(2.0 / n) * ACROSS ** 2         # 4 SE of a variance estimate
    assert np.allclose(got, cov, atol=tol), got
    assert np.allclose(c, cov, atol=1e-12)           # the conditional covariance


def test_standing_holds_the_last_direction():
    m = street_model()
    keys = streams.agent_keys(2, ['a'])
    zoned = StepsPerFix(m, 1, conditional_cov=True)
    zoned.restart(0)
    zoned.errors([0], keys, 0, None, [math.pi / 2])
    _, c = zoned.errors([0], keys, 1, None, [math.nan])
    assert np.allclose(c[0], [[ACROSS ** 2, 0], [0, ALONG ** 2]])


def test_travel_directions_of_a_streamed_walk():
    td = TravelDirections()
    # north 1.4 m/s, then standing, then east: 1e-5 deg of latitude is ~1.1 m
    steps = [(0, 40.0, -73.0), (1, 40.0000126, -73.0), (2, 40.0000252, -73.0),
             (3, 40.0000252, -73.0), (4, 40.0000252, -72.9999834)]
    got = [td.directions(['w'], t, [lat], [lon])[0] for t, lat, lon in steps]
    assert math.isnan(got[0]) and math.isnan(got[3])      # no history; standing
    assert got[1] == pytest.approx(0.0, abs=1e-6) and got[2] == pytest.approx(0.0, abs=1e-6)
    assert got[4] == pytest.approx(math.pi / 2, abs=1e-3)


def test_a_street_frame_keeps_its_failures_and_its_population():
    """A street frame steps per fix: its failures and its population are the model's."""
    from gps_error_ros.model.failures import GrossFailureProcess, WithFailures
    from gps_error_ros.model.population import Population, WithPopulation
    m = street_model()
    fails = GrossFailureProcess(0.3, (70.0,))
    keys = streams.agent_keys(5, ['a', 'b'])
    plain = StepsPerFix(m, conditional_cov=True)
    failing = StepsPerFix(WithFailures(m, fails), conditional_cov=True)
    for z in (plain, failing):
        z.grow(2)
        z.restart(0)
    got = [(plain.errors([0, 1], keys, k, None, [0.0, 0.0])[0],
            failing.errors([0, 1], keys, k, None, [0.0, 0.0])[0]) for k in range(200)]
    a, b = np.array(got).transpose(1, 0, 2, 3)
    failed = np.any(a != b, axis=2)
    assert 0.2 < failed.mean() < 0.4
    np.testing.assert_allclose(np.hypot(*b[failed].T), 70.0)
    # a population: the same process, each agent's scale and its run's wandering bias
    section = Population(bias_sd_m=(1.0, 2.0), scale_sd_log=0.3, bias_time_constant_s=20.0)
    with_pop = WithPopulation(m, section)
    pop, again = StepsPerFix(with_pop, conditional_cov=True), StepsPerFix(m, conditional_cov=True)
    for z in (pop, again):
        z.grow(2)
        z.restart(0)
    draws = with_pop.draws
    f, (bias, g) = draws.scales(keys), draws.run_bias(keys, 0)
    assert np.ptp(f) > 0.01             # two agents, two scales
    for k in range(200):
        if k:
            draws.wander(bias, g, keys, k)
        err, cov = pop.errors([0, 1], keys, k, None, [0.0, 0.0])
        e, c = again.errors([0, 1], keys, k, None, [0.0, 0.0])
        np.testing.assert_allclose(e, a[k], atol=1e-12)
        np.testing.assert_allclose(err, m.mean + f[:, None] * (e - m.mean) + bias, atol=1e-12)
        expected = c + np.diag([1.0, 4.0]) if k == 0 else \
            f[:, None, None] ** 2 * c + np.diag(draws.wander_sd ** 2)
        np.testing.assert_allclose(cov, expected, atol=1e-12)
    assert not np.allclose(c[0], m.stationary_cov)     # given the state: not the law

"""
The first fix's stated covariance: the law the first error is drawn from.

A run's first error is drawn from the stationary law, so the covariance a
model states for it (``predictive_cov(state, first=True)``, the node's
``covariance_mode`` conditional) is the stationary one, not the one-step
(innovation) covariance of later steps. Judged over many agents: the
squared Mahalanobis distance of the first errors about the stated mean and
covariance has mean 2 whatever the law's shape (``E[x' S^-1 x] = tr(S^-1
Cov x)``), so a covariance too small by a factor ``c`` shows as ``2 c``.
"""

import numpy as np
import pytest
import yaml

from gps_error_ros.model import streams
from gps_error_ros.model.profiles import builtin_dir, profile_from_dict
from gps_error_ros.model.stepping import StepsPerFix

AGENTS = 5000
POPULATION = {'bias_sd_m': [2.0, 3.0], 'scale_sd_log': 0.3, 'bias_time_constant_s': 200.0,
              'run_bias_sd_m': [1.0, 1.5]}
EFFECTS = {'variance_regimes': {'scales': [1.0, 2.5], 'transition': [[0.9, 0.1], [0.2, 0.8]]},
           'periodic': {'period_steps': 4, 'scales': [2.0, 0.5, 1.0, 0.8],
                        'offsets': [[0.3, 0.0], [-0.3, 0.1], [0.0, -0.1], [0.0, 0.0]]},
           'outliers': {'rate': 0.05, 'mean_steps': 2.0, 'sigma_m': 5.0}}
STREET = {'street_frame': {'sigma_along': 0.6, 'sigma_across': 1.4}}
AVAILABILITY = {'outage_rate': 0.01, 'durations': [[5, 0.5], [20, 0.5]]}
# failures are surprises a covariance does not state: so rare here that none occurs
FAILURES = {'rate': 1e-9, 'sizes_m': [300.0, 1000.0, 5000.0]}


def _profile(**sections):
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw.update(sections)
    return profile_from_dict(raw, 'test')


def _mahalanobis(err, mean, cov):
    d = err - mean
    return np.einsum('ni,nij,nj->n', d, np.linalg.inv(cov), d)


CASES = {
    'plain AR': {},
    'effects (regimes, periodic, jumps)': {'effects': EFFECTS},
    'population': {'population': POPULATION},
    'effects and population': {'effects': EFFECTS, 'population': POPULATION},
    'availability and failures': {'availability': AVAILABILITY, 'gross_failures': FAILURES},
}


@pytest.mark.parametrize('about_truth', [False, True], ids=['about the mean', 'about the truth'])
@pytest.mark.parametrize('case', CASES, ids=list(CASES))
def test_the_first_errors_fit_their_stated_covariance(case, about_truth):
    profile = _profile(**CASES[case])
    model = profile.model(about_truth=about_truth)
    keys = streams.agent_keys(8, [f'a{i}' for i in range(AGENTS)])
    state = model.initial_state(keys, 100)
    cov = model.predictive_cov(state, first=True)
    err = model.errors(state)
    mean = 0.0 if about_truth else model.predictive_mean(state, first=True)
    d2 = _mahalanobis(err, mean, cov)
    # 5000 agents: the mean of a chi-square(2) has SE 0.03 (heavier laws: a little more);
    # the one-step covariance gave 43 for DS5
    assert abs(d2.mean() - 2.0) < 0.25, d2.mean()
    # the stated first covariance is the stationary law's, whatever wraps it
    np.testing.assert_allclose(cov[0], model.stationary_cov, rtol=1e-12)


def test_ds5_first_fix_states_the_stationary_spread_not_the_innovations():
    model = _profile().model()
    keys = streams.agent_keys(1, ['only'])
    cov = model.predictive_cov(model.initial_state(keys, 0), first=True)[0]
    sd = np.sqrt(np.diag(cov))
    # DS5's innovations are 3.8 / 1.9 m (north / east); its stationary SD is several times that
    assert np.all(sd > 2.0 * np.sqrt(np.diag(model.innovation_cov))), sd
    np.testing.assert_allclose(sd, model.stationary_sd, rtol=1e-12)


@pytest.mark.parametrize('population', [False, True], ids=['alone', 'with a population'])
def test_the_zone_path_states_the_stationary_law_at_the_first_step(population):
    sections = {'effects': STREET}
    if population:
        sections['population'] = POPULATION
    profile = _profile(**sections)
    model = profile.model(about_truth=True)
    zoned = StepsPerFix(model, conditional_cov=True)
    keys = streams.agent_keys(5, [f'w{i}' for i in range(AGENTS)])
    zoned.grow(AGENTS)
    zoned.restart(0)
    heading = np.linspace(0.0, 2 * np.pi, AGENTS, endpoint=False)
    err, cov = zoned.errors(np.arange(AGENTS), keys, 0, np.full(AGENTS, -1), heading)
    d2 = _mahalanobis(err, 0.0, cov)
    assert abs(d2.mean() - 2.0) < 0.25, d2.mean()

"""The Gaussian population class is scored by the exact predictive of the model it simulates."""

import numpy as np
import pytest
from scipy import stats

from gps_error_ros.judge.population_class import _kalman_ll
from gps_error_ros.fit.holdout import Part
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams


@pytest.mark.parametrize('held', [0.0, 3.0], ids=['one part', 'a part held for the run'])
def test_the_kalman_filter_gives_the_exact_gaussian_likelihood(held):
    """The summed one-step log densities are the joint density of the series, bias and all."""
    phi, sigma_w, bias_sd, rate, mean, n = (0.8, -0.1), 0.7, 1.5, 0.95, 0.4, 60
    rng = np.random.default_rng(3)
    y = mean + rng.normal(0.0, 2.0, n)
    part = Part([np.c_[y, y]], [np.zeros((n, 2))], [np.arange(n, dtype=float)])
    got = _kalman_ll(part, 0, np.array(phi), sigma_w, mean, bias_sd, rate, held)
    acv = ARErrorModel(*(AxisParams(0.0, phi, sigma_w),) * 2).autocovariance(n)[:, 0, 0]
    lag = np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    cov = acv[lag] + bias_sd ** 2 * rate ** lag + held ** 2
    want = stats.multivariate_normal(cov=cov).logpdf(y - mean)
    np.testing.assert_allclose(got.sum(), want, rtol=1e-9)

"""Yule-Walker against statsmodels and by round trip."""

import numpy as np
import pytest
from statsmodels.regression.linear_model import yule_walker as sm_yw

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.fit.yule_walker import yule_walker


def test_matches_statsmodels():
    model = ARErrorModel(AxisParams(0.2, (1.2, -0.1, -0.2), 0.8),
                         AxisParams(-0.1, (0.7,), 1.1))
    x = model.simulate(streams.agent_key(1), 3000)[:, 0, 0]
    ours = yule_walker(x, 3)
    rho, sigma = sm_yw(x, order=3, method='mle', demean=True,
                       result_object=False)
    np.testing.assert_allclose(ours.phi, rho, rtol=1e-10)
    np.testing.assert_allclose(ours.sigma_w, sigma, rtol=1e-10)


def test_round_trip_recovers_parameters():
    true = AxisParams(0.5, (0.9, -0.3, 0.1), 0.7)
    model = ARErrorModel(true, true)
    x = model.simulate(streams.agent_key(2), 20000)[:, 0, 0]
    fit = yule_walker(x, 3)
    # asymptotic SE of phi-hat ~ 1/sqrt(n) for these values; 5 SE bounds
    np.testing.assert_allclose(fit.phi, true.phi, atol=5 / np.sqrt(x.size))
    assert abs(fit.sigma_w - 0.7) < 5 * 0.7 / np.sqrt(2 * x.size)
    assert abs(fit.mean - true.mean) < 0.2


def test_refusals():
    with pytest.raises(ValueError, match='too few'):
        yule_walker(np.arange(5.0), 3)
    with pytest.raises(ValueError, match='constant'):
        yule_walker(np.ones(100), 2)
    with pytest.raises(ValueError, match='finite'):
        yule_walker(np.r_[np.zeros(50), np.nan], 1)

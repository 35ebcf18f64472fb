"""The AR model against exact theory, statsmodels and long simulations."""

import numpy as np
import pytest
from statsmodels.tsa.arima_process import ArmaProcess

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ar_roots, ARErrorModel, AxisParams, \
    is_stationary, ModelError
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.fit.autocorrelation import variance_se

FITTED = ('DS1', 'DS2', 'DS5', 'DS7')


@pytest.mark.parametrize('name', FITTED)
def test_stationary_moments_match_statsmodels(name):
    model = load_profile(name).model()
    acv = model.autocovariance(40)
    for a, axis in enumerate(model.axes):
        oracle = ArmaProcess(np.r_[1.0, -np.array(axis.phi)], [1.0]).acovf(41)
        np.testing.assert_allclose(acv[:, a, a], oracle * axis.sigma_w ** 2,
                                   rtol=1e-9)
    assert np.all(acv[:, 0, 1] == 0.0)   # independent axes
    np.testing.assert_allclose(model.mean, [ax.mean for ax in model.axes])


@pytest.mark.parametrize('name', FITTED)
def test_stationary_variance_equals_long_simulation(name):
    """Many independent agents at one instant sample the stationary law."""
    model = load_profile(name).model()
    keys = streams.agent_keys(11, [f'a{i}' for i in range(400)])
    x = model.simulate(keys, 2000)            # (time, agent, axis)
    var_theory = np.diag(model.stationary_cov)
    # 400 independent chains; within a chain the samples are correlated, so
    # the standard error uses the exact autocorrelation (Bartlett).
    rho = model.autocorrelation(2000)
    for a in range(2):
        per_chain = x[:, :, a].var(axis=0, ddof=0)
        se = variance_se(rho[:, a], 2000, var_theory[a]) / np.sqrt(400)
        assert abs(per_chain.mean() - var_theory[a]) < 5 * se + 0.01 * var_theory[a]
        assert abs(x[:, :, a].mean() - model.mean[a]) < \
            5 * np.sqrt(var_theory[a] * (1 + 2 * rho[1:, a].sum()) / x[:, :, a].size)


def test_initial_state_is_stationary():
    """The first sample of many agents already has the stationary spread."""
    model = load_profile('DS5').model()
    keys = streams.agent_keys(3, [str(i) for i in range(20000)])
    x0 = model.simulate(keys, 3)
    for t in range(3):
        sd = x0[t].std(axis=0)
        np.testing.assert_allclose(sd, model.stationary_sd, rtol=0.03)
    # lag-1 covariance of the initial state is the stationary one
    c = np.mean((x0[1] - model.mean) * (x0[0] - model.mean), axis=0)
    acv = model.autocovariance(1)
    np.testing.assert_allclose(c, [acv[1, 0, 0], acv[1, 1, 1]], rtol=0.05)


def test_same_seed_same_sequence_and_different_seed_differs():
    model = load_profile('DS2').model()
    a = model.simulate(streams.agent_key(42), 500)
    b = model.simulate(streams.agent_key(42), 500)
    c = model.simulate(streams.agent_key(43), 500)
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)


def test_agent_alone_equals_agent_in_crowd():
    model = load_profile('DS7').model()
    keys = streams.agent_keys(5, ['x', 'y', 'z'])
    crowd = model.simulate(keys, 300, start=1000)
    alone = model.simulate(keys[1:2], 300, start=1000)
    assert np.array_equal(crowd[:, 1], alone[:, 0])


def test_sign_convention_and_stationarity():
    # e(t) = 0.5 e(t-1): root of 1 - 0.5 z at z = 2
    np.testing.assert_allclose(ar_roots([0.5]), [2.0])
    assert is_stationary([0.5])
    assert not is_stationary([1.0])
    assert not is_stationary([1.2, -0.1])       # sum > 1
    assert is_stationary([1.71, -0.75, -0.04])  # DS1 north


@pytest.mark.parametrize('kwargs, match', [
    (dict(delta=0.0, phi=(1.1,), sigma_w=1.0), 'not stationary'),
    (dict(delta=0.0, phi=(0.5,), sigma_w=0.0), 'sigma_w'),
    (dict(delta=0.0, phi=(0.5,), sigma_w=1e-200), 'sigma_w'),
    (dict(delta=float('nan'), phi=(0.5,), sigma_w=1.0), 'finite'),
    (dict(delta=0.0, phi=(), sigma_w=1.0), 'at least one'),
])
def test_invalid_axis_params(kwargs, match):
    with pytest.raises(ModelError, match=match):
        AxisParams(**kwargs)


def test_orders_may_differ_and_correlated_innovations_are_exact():
    n = AxisParams(0.1, (0.6,), 1.0)
    e = AxisParams(-0.2, (0.5, 0.2, -0.1, 0.05), 2.0)
    model = ARErrorModel(n, e, innovation_corr=0.6)
    assert model.order == 4
    keys = streams.agent_keys(9, [str(i) for i in range(200)])
    x = model.simulate(keys, 500).reshape(-1, 2)
    np.testing.assert_allclose(np.cov(x.T), model.stationary_cov, rtol=0.08)


@pytest.mark.parametrize('n, exact', [(40, False), (1500, True)])
def test_batch_path_equals_the_node_step_path(n, exact):
    """The batch path (simulate) and the node's per-step path agree."""
    model = ARErrorModel(AxisParams(0.2, (1.2, -0.3, 0.05), 0.7),
                         AxisParams(-0.3, (0.9,), 1.2), innovation_corr=0.4)
    keys = streams.agent_keys(13, [f'p{i}' for i in range(n)])
    batch = model.simulate(keys, 200, start=77)
    state = model.initial_state(keys, 77)
    steps = [model.errors(state)] + [model.advance(state, keys, k)
                                     for k in range(78, 277)]
    steps = np.array(steps)
    if exact:      # crowds run the node's own arithmetic
        assert np.array_equal(batch, steps)
    else:          # few long series run through lfilter
        np.testing.assert_allclose(batch, steps, rtol=0, atol=1e-9)


def test_agent_values_do_not_depend_on_the_crowd():
    model = load_profile('DS5').model()
    keys = streams.agent_keys(2, [f'p{i}' for i in range(3000)])
    crowd = model.simulate(keys, 50)
    small = model.simulate(keys[:1100], 50)      # another chunking, same path
    assert np.array_equal(crowd[:, :1100], small)
    alone = model.simulate(keys[5:6], 50)        # lfilter path
    np.testing.assert_allclose(alone[:, 0], crowd[:, 5], rtol=0, atol=1e-9)

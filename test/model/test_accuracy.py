"""Stated accuracy: the J2735 ellipse and Android's 68 % radius of a covariance."""

import numpy as np
import pytest

from gps_error_ros.model import streams
from gps_error_ros.model.accuracy import ellipse, radius68
from gps_error_ros.model.effects import build_model, effects_from_dict
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.sim.simulate import simulate_csv
from gps_error_ros.traces.trace_io import read_trace_csv


def test_ellipse_axes_and_orientation():
    rot = np.radians(30.0)          # major axis 30 deg east of north
    r = np.array([[np.cos(rot), -np.sin(rot)], [np.sin(rot), np.cos(rot)]])
    cov = r @ np.diag([9.0, 1.0]) @ r.T
    major, minor, orientation = ellipse(cov)
    assert (major, minor, orientation) == pytest.approx((3.0, 1.0, 30.0))
    assert ellipse(np.diag([1.0, 4.0]))[2] == pytest.approx(90.0)    # east-west


def test_radius68_against_closed_form_and_sampling():
    assert radius68(np.eye(2) * 4.0) == pytest.approx(2.0 * np.sqrt(-2 * np.log(0.32)))
    cov = np.array([[9.0, 1.5], [1.5, 2.0]])
    x = np.random.default_rng(3).multivariate_normal([0, 0], cov, 200_000)
    assert radius68(cov) == pytest.approx(np.quantile(np.hypot(*x.T), 0.68), rel=0.01)


@pytest.mark.parametrize('mode', ['stationary', 'conditional'])
def test_simulate_states_the_accuracy_of_its_covariance_mode(tmp_path, mode):
    raw = {'variance_regimes': {'scales': [1.0, 3.0], 'transition': [[0.9, 0.1], [0.3, 0.7]]}}
    ds1 = load_profile('DS1')
    model = build_model(ds1.axes['north'], ds1.axes['east'], effects_from_dict(raw))
    src = tmp_path / 'truth.csv'
    src.write_text('t,truth_lat,truth_lon\n' + ''.join(
        f'{t},40.75,-73.99\n' for t in range(200)))
    simulate_csv(src, tmp_path / 'o.csv', model, 1.0, 3, covariance_mode=mode)
    ex = read_trace_csv(tmp_path / 'o.csv').extra
    if mode == 'stationary':
        want = model.stationary_cov[None].repeat(200, axis=0)
    else:                          # the model's prediction a step before, from the stream
        key = np.array([streams.agent_key(3, '')], dtype=np.uint64)
        state = model.initial_state(key, 0)
        want = [model.predictive_cov(state, first=True)[0]]
        for k in range(1, 200):
            want.append(model.predictive_cov(state)[0])
            model.advance(state, key, k)
        want = np.array(want)
    major, minor, orientation = ellipse(want)
    np.testing.assert_allclose(ex['accuracy_major'], major, rtol=1e-9)
    np.testing.assert_allclose(ex['accuracy_minor'], minor, rtol=1e-9)
    np.testing.assert_allclose(ex['accuracy'], radius68(want), rtol=1e-6)
    assert len(set(np.round(ex['accuracy'], 6))) == (1 if mode == 'stationary' else 3)

"""The stated covariance covers the error about the truth: a chi-squared check of the node."""

import numpy as np
import pytest
from scipy import stats
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.profiles import profile_from_dict
from ros_harness import covariances_ne, DATUM, errors, standing_fixes

pytestmark = pytest.mark.integration
STEPS = 400
# mean error 5 m north, -4 m east (delta / (1 - phi)), SD about 1.15 m per axis
BIASED = {'schema': 1, 'name': 'biased', 'description': 'a phone with a large mean error',
          'source': 'test', 'rate_hz': 1.0,
          'axes': {'north': {'delta': 2.5, 'phi': [0.5], 'sigma_w': 1.0},
                   'east': {'delta': -2.0, 'phi': [0.5], 'sigma_w': 1.0}}}
Q95 = float(stats.chi2.ppf(0.95, 2))


def _expected_inside():
    """Return the share of errors the mean-square ellipse holds at the 95 % radius (exact law)."""
    model = profile_from_dict(BIASED).model()
    stated = profile_from_dict(BIASED).model(about_truth=True).stationary_cov
    z = np.random.default_rng(0).multivariate_normal(model.mean, model.stationary_cov, 200000)
    d2 = np.einsum('ni,ij,nj->n', z, np.linalg.inv(stated), z)
    return float(np.mean(d2 <= Q95))


def _fixes(tmp_path, peer, *params):
    import yaml
    path = tmp_path / 'biased.yaml'
    path.write_text(yaml.safe_dump(BIASED))
    return standing_fixes(peer, path, STEPS, 'seed:=11', *params)


def _d2(box):
    err = errors(box, DATUM[0], DATUM[1])
    return np.einsum('ni,nij,nj->n', err, np.linalg.inv(covariances_ne(box)), err), err


def test_fixes_lie_within_the_stated_covariance_about_the_truth(tmp_path, peer):
    box = _fixes(tmp_path, peer)
    d2, err = _d2(box)
    assert len(box) >= STEPS - 1
    assert abs(err[:, 0].mean() - 5.0) < 0.6 and abs(err[:, 1].mean() + 4.0) < 0.6
    # E[e' S^-1 e] = trace(S^-1 (C + m m')) = 2 for the mean-square matrix S
    assert 1.6 < d2.mean() < 2.4, d2.mean()
    inside, want = float(np.mean(d2 <= Q95)), _expected_inside()
    # 400 steps of an AR(1) with phi 0.5: about 133 independent ones
    assert abs(inside - want) < 4 * np.sqrt(want * (1 - want) / 133), (inside, want)
    kinds = {f.position_covariance_type for f in box}
    assert kinds == {NavSatFix.COVARIANCE_TYPE_KNOWN}      # m m' couples the axes


def test_about_the_mean_leaves_the_bias_out(tmp_path, peer):
    d2, _ = _d2(_fixes(tmp_path, peer, 'covariance_about:=mean'))
    assert d2.mean() > 15.0                     # (5^2 + 4^2) / 1.33 + 2 ~ 33: far outside
    assert np.mean(d2 <= Q95) < 0.2

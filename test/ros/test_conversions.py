"""The fix covariance as NavSatFix states it: ENU order and the covariance type."""

import numpy as np
import pytest
from sensor_msgs.msg import NavSatFix

from gps_error_ros.model.profiles import load_profile
from gps_error_ros.ros.conversions import enu_covariance


def test_round_off_off_diagonal_is_diagonal():
    """A profile without coupling gave -2.75e-17 off the diagonal and type KNOWN."""
    cov, kind = enu_covariance([[0.0121, -2.75e-17], [-2.75e-17, 0.0484]], 1.0)
    assert kind == NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    assert cov == [0.0484, 0.0, 0.0, 0.0, 0.0121, 0.0, 0.0, 0.0, 1.0]


@pytest.mark.parametrize('corr', [1e-6, -0.3])
def test_a_real_correlation_is_kept(corr):
    c = corr * np.sqrt(4.0 * 9.0)
    cov, kind = enu_covariance([[4.0, c], [c, 9.0]], 1.0)
    assert kind == NavSatFix.COVARIANCE_TYPE_KNOWN
    assert cov[:5] == [9.0, c, 0.0, c, 4.0]


def test_builtin_profiles_are_diagonal_about_their_mean():
    for name in ('DS1', 'DS2', 'DS5', 'DS7'):
        model = load_profile(name).model()
        assert enu_covariance(model.stationary_cov, 1.0)[1] == \
            NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN, name

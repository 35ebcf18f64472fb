"""
A downstream filter meets the node's gross failures: a gate on the covariance rejects them.

The node serves a profile with a ``gross_failures`` section; a constant-
position Kalman filter (as a localisation stack would run on a standing
pedestrian) fuses its fixes with the published covariance and a chi-squared
gate at 0.999. The failed fixes, hundreds of metres off, are the ones it
rejects, and the filter stays where the truth is; fused without the gate,
they drag it away.
"""

import numpy as np
import pytest
import yaml
from scipy import stats

from gps_error_ros.model.profiles import builtin_dir
from ros_harness import covariances_ne, DATUM, errors, standing_fixes

pytestmark = pytest.mark.integration
STEPS = 240
GATE = float(stats.chi2.ppf(0.999, 2))


def _filter(z, covs, gate=True, q=0.5):
    """Return (estimates, rejected) of a constant-position Kalman filter over fixes ``z``."""
    x, p = z[0].copy(), covs[0].copy()
    out, rejected = [], []
    for zk, rk in zip(z, covs):
        p = p + q * np.eye(2)
        s = p + rk
        nu = zk - x
        d2 = float(nu @ np.linalg.solve(s, nu))
        rejected.append(gate and d2 > GATE)
        if not rejected[-1]:
            k = p @ np.linalg.inv(s)
            x, p = x + k @ nu, (np.eye(2) - k) @ p
        out.append(x.copy())
    return np.array(out), np.array(rejected)


def test_a_gated_filter_rejects_the_failed_fixes(tmp_path, peer):
    raw = yaml.safe_load((builtin_dir() / 'DS2.yaml').read_text())
    raw['gross_failures'] = {'rate': 0.04, 'sizes_m': [300.0, 900.0, 5000.0]}
    path = tmp_path / 'failing.yaml'
    path.write_text(yaml.safe_dump(raw))
    box = standing_fixes(peer, path, STEPS, 'seed:=21')
    z = errors(box, DATUM[0], DATUM[1])                 # north/east of the truth, m
    covs = covariances_ne(box)
    failed = np.hypot(z[:, 0], z[:, 1]) > 250.0
    assert 3 <= failed.sum() <= 25, failed.sum()         # 4 % of 240, all 300 m or more
    est, rejected = _filter(z, covs)
    assert rejected[failed].all()                        # every failure is gated out
    assert rejected[~failed].mean() < 0.02
    assert np.hypot(*est.T).max() < 20.0                 # the estimate stays near the truth
    dragged, _ = _filter(z, covs, gate=False)
    assert np.hypot(*dragged.T).max() > 50.0             # ungated, the failures pull it away

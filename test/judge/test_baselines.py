"""The model classes simulators use today, fitted and scored like ours."""

import numpy as np
import pytest
from scipy import signal

from gps_error_ros.diagnose import diagnose
from gps_error_ros.judge.baselines import Arma11, CLASSES, compare
from gps_error_ros.fit.holdout import Part
from gps_error_ros.sim.synthetic import synthetic_trace


def test_arma11_recovers_known_parameters():
    rng = np.random.default_rng(4)
    segs = []
    for _ in range(2):
        w = rng.normal(size=(3000, 2))
        x = np.stack([signal.lfilter([1, -0.4], [1, -0.8], w[:, a]) for a in range(2)], 1)
        segs.append(x[500:] + [1.0, -2.0])
    part = Part(segs, [np.zeros_like(s) for s in segs], [np.arange(len(s)) for s in segs])
    arma = Arma11().fit(part, 5)
    for mu, phi, theta, var in arma.params:
        assert phi == pytest.approx(0.8, abs=0.05)
        assert theta == pytest.approx(-0.4, abs=0.07)
        assert var == pytest.approx(1.0, rel=0.05)


def test_classes_score_the_same_samples_as_the_diagnosis():
    d = diagnose(synthetic_trace('street_ellipse', 2, 2400), sims=10)
    table = compare(d, sims=10)
    assert list(table) == list(CLASSES)
    nll = {k: v['heldout_nll_per_sample'] for k, v in table.items()}
    assert nll['extended'] == pytest.approx(d.findings.error_after.heldout_nll_per_sample)
    assert nll['AR(p), PACF'] == pytest.approx(
        d.findings.error_before.heldout_nll_per_sample)
    assert nll['white noise + bias'] > nll['AR(p), PACF']

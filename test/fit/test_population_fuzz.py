"""The population fit on generated runs: a valid section or none, never a NaN or a warning."""

import warnings

from hypothesis import given, settings, strategies as st
import numpy as np
from scipy.signal import lfilter

from gps_error_ros.fit.population_fit import fit_population, population_line
from gps_error_ros.model.population import population_from_dict


@st.composite
def runs(draw):
    """Draw runs of AR errors with their own biases, one after another, and their weights."""
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    k = draw(st.integers(1, 6))
    phi = draw(st.sampled_from([0.0, 0.5, 0.98]))
    scale = draw(st.sampled_from([0.0, 1e-3, 1.0, 20.0]))
    spread = draw(st.sampled_from([0.0, 1.0, 10.0]))
    wander = draw(st.sampled_from([0.0, 3.0]))      # a bias that moves within a run
    segs, times, t0 = [], [], 0.0
    for _ in range(k):
        n = draw(st.one_of(st.integers(2, 400), st.integers(600, 1500)))
        e = lfilter([scale], [1.0, -phi], rng.standard_normal((n, 2)), axis=0)
        e += spread * rng.standard_normal(2)
        e += lfilter([wander * 0.077], [1.0, -0.997], rng.standard_normal((n, 2)), axis=0)
        cut = draw(st.integers(0, n - 1))           # a gap inside the run, or none
        gap = draw(st.sampled_from([0.0, 30.0, 500.0]))
        t = t0 + np.arange(n, dtype=float) + np.where(np.arange(n) >= cut, gap, 0.0)
        for piece, tt in ((e[:cut], t[:cut]), (e[cut:], t[cut:])):
            if len(piece):
                segs.append(piece)
                times.append(tt)
        t0 = float(t[-1]) + 1000.0
    weights = [draw(st.sampled_from([1.0, 0.5, 1.0 / 3.0])) for _ in segs]
    return segs, times, weights


@settings(max_examples=50, deadline=None)
@given(runs(), st.booleans())
def test_the_fit_gives_a_valid_section_or_none(data, two_scales):
    segs, times, weights = data
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        try:
            fit = fit_population(segs, times, weights=weights, two_scales=two_scales)
        except ValueError as exc:       # a within fit that cannot be made says why
            assert str(exc), exc
            return
        line = population_line(fit)
    assert 'nan' not in line and 'inf' not in line, line
    if fit.population is None:
        return
    section = fit.population.to_dict()
    assert population_from_dict(section).to_dict() == section      # what a profile reads back
    values = np.array([v for x in section.values() for v in np.atleast_1d(x)], dtype=float)
    assert np.all(np.isfinite(values)), section
    if not two_scales:
        assert 'run_bias_sd_m' not in section

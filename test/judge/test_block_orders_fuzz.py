"""The blocks' AR orders on generated parts: orders in range and finite gains, or none."""

import warnings

from hypothesis import given, settings, strategies as st
import numpy as np

from gps_error_ros.judge.beaten import block_orders
from gps_error_ros.fit.holdout import Part


@st.composite
def parts(draw):
    """Draw a part of segments with gaps, errors white, constant, tiny or huge."""
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    err, t, t0 = [], [], 0.0
    for _ in range(draw(st.integers(1, 5))):
        n = draw(st.one_of(st.integers(1, 80), st.integers(250, 900)))
        scale = draw(st.sampled_from([0.0, 1e-9, 1.0, 1e4]))
        e = scale * rng.standard_normal((n, 2)) + draw(st.sampled_from([0.0, 5.0]))
        if draw(st.booleans()):
            e[:, 1] = 3.0                              # one axis constant
        err.append(e)
        t.append(t0 + np.arange(n, dtype=float))
        t0 = t[-1][-1] + 1.0 + draw(st.sampled_from([0.0, 40.0, 700.0]))
    return Part(err, [None] * len(err), t)


@settings(max_examples=60, deadline=None)
@given(parts())
def test_block_orders_gives_orders_in_range_or_none(part):
    with warnings.catch_warnings():
        warnings.simplefilter('error')                 # no numpy warning reaches a user
        got = block_orders(part)
    if got is None:
        return
    assert got['blocks'] >= 3
    for axis in ('north', 'east'):
        assert 1 <= got[axis]['order'] <= 10, got
        assert np.isfinite(got[axis]['gain_per_sample']) and got[axis]['gain_per_sample'] >= 0

"""The diagnosis's library functions leave each recording's gross failures out themselves."""

from dataclasses import replace

import numpy as np

from gps_error_ros.diagnose.pipeline import fit_models
from gps_error_ros.sim.synthetic import synthetic_trace


def _with_failures(trace, rows, name):
    """Return ``trace`` renamed, its fixes at ``rows`` moved 5.6 km north (failed solutions)."""
    lat = trace.lat.copy()
    lat[rows] += 0.05
    return replace(trace, name=name, lat=lat)


def test_fit_models_finds_and_leaves_out_each_recordings_failures():
    a = synthetic_trace('none', 3, 900)
    b = synthetic_trace('none', 4, 900)
    clean = fit_models([replace(a, name='a'), replace(b, name='b')])
    dirty = fit_models([_with_failures(a, [100, 101, 500], 'a'),
                        _with_failures(b, [700], 'b')])
    assert [(f.name, f.count) for f in dirty.failures] == [('a', 3), ('b', 1)]
    np.testing.assert_allclose(dirty.failures[0].size_m, 5560.0, rtol=0.01)
    assert [f.count for f in clean.failures] == [0, 0]
    # the fit sees the failures as missing steps: the base model is the clean fit's to
    # within what 4 fewer samples of 1,800 change, not kilometres of sigma_w
    for axis in ('north', 'east'):
        got = dirty.base.parameters()[axis]['sigma_w']
        ref = clean.base.parameters()[axis]['sigma_w']
        assert abs(got / ref - 1.0) < 0.02, (axis, got, ref)
    assert dirty.split.train.n + dirty.split.test.n == clean.split.train.n + clean.split.test.n - 4

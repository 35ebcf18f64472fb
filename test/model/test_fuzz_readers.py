"""Property-based tests: parsers fail only with their documented errors."""

import numpy as np
import pytest
from hypothesis import example, given, HealthCheck, settings, strategies as st
import yaml

from gps_error_ros.model.geodesy import difference, offset
from gps_error_ros.model.profiles import (load_profile_file, profile_from_dict, ProfileError,
                                          ProfileNotFittedError)
from gps_error_ros.traces.trace_io import read_trace_csv, TraceError

SETTINGS = settings(max_examples=150, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])

scalars = st.one_of(st.none(), st.booleans(), st.integers(), st.text(max_size=5),
                    st.floats(allow_nan=True, allow_infinity=True))
values = st.recursive(scalars, lambda c: st.one_of(
    st.lists(c, max_size=4), st.dictionaries(st.text(max_size=8), c, max_size=4)),
    max_leaves=12)
axis = st.fixed_dictionaries({
    'delta': st.floats(-5, 5),
    'phi': st.lists(st.floats(-2, 2), min_size=1, max_size=4),
    'sigma_w': st.floats(-1, 3)})
profiles = st.fixed_dictionaries(
    {'schema': st.sampled_from([1, 1, 2]), 'name': st.text(max_size=6),
     'description': st.text(max_size=6), 'source': st.text(max_size=6),
     'rate_hz': st.floats(-1, 5)},
    optional={'axes': st.fixed_dictionaries({'north': axis, 'east': axis}),
              'vertical_sd': st.floats(-1, 5), 'junk': values})


@SETTINGS
@given(values)
def test_any_yaml_value_loads_or_raises_profile_error(raw):
    try:
        p = profile_from_dict(raw, 'fuzz')
    except ProfileError:
        return
    assert p.name


@SETTINGS
@given(profiles)
@example({'schema': 1, 'name': '0', 'description': '', 'source': '', 'rate_hz': 1.0,
          'axes': {'north': {'delta': 0.0, 'phi': [2.225073858507e-311], 'sigma_w': 1.0},
                   'east': {'delta': 0.0, 'phi': [0.0], 'sigma_w': 1.0}}})
@example({'schema': 1, 'name': '0', 'description': '', 'source': '', 'rate_hz': 1.0,
          'axes': {'north': {'delta': 0.0, 'phi': [0.0], 'sigma_w': 1.0},
                   'east': {'delta': 0.0, 'phi': [0.0], 'sigma_w': 1.2e-184}}})
def test_profile_like_mappings(raw):
    try:
        p = profile_from_dict(raw, 'fuzz')
    except ProfileError:
        return
    if p.fitted:                        # a valid profile gives a stationary model
        m = p.model()
        assert np.all(np.isfinite(m.stationary_cov)) and np.all(m.stationary_sd > 0)


@SETTINGS
@given(st.binary(max_size=300))
def test_profile_file_bytes(tmp_path_factory, data):
    f = tmp_path_factory.mktemp('p') / 'x.yaml'
    f.write_bytes(data)
    try:
        p = load_profile_file(f)
    except ProfileError:
        return
    # whatever loads is usable: a model with a finite, positive spread, or a
    # placeholder that says it has no fit
    if p.fitted:
        m = p.model()
        assert np.all(np.isfinite(m.stationary_cov)) and np.all(m.stationary_sd > 0)
    else:
        with pytest.raises(ProfileNotFittedError):
            p.model()


@SETTINGS
@given(profiles)
def test_valid_profiles_round_trip_through_yaml(tmp_path_factory, raw):
    try:
        p = profile_from_dict(raw, 'fuzz')
    except ProfileError:
        return
    f = tmp_path_factory.mktemp('p') / 'x.yaml'
    f.write_text(yaml.safe_dump(raw))
    q = load_profile_file(f)
    assert (q.name, q.axes, q.rate_hz) == (p.name, p.axes, p.rate_hz)


cells = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                  st.text(alphabet='0123456789.-e,x "\r', max_size=6))


@SETTINGS
@given(st.lists(st.lists(cells, min_size=0, max_size=7), max_size=6),
       st.sampled_from(['t,lat,lon,truth_lat,truth_lon', 't,lat,lon,truth_lat',
                        '\ufefft,lat,lon,truth_lat,truth_lon,alt', '']),
       st.sampled_from(['\n', '\r\n']))
def test_trace_csv_reader(tmp_path_factory, rows, header, eol):
    f = tmp_path_factory.mktemp('c') / 'x.csv'
    f.write_text(eol.join([header] + [','.join(r) for r in rows]) + eol)
    try:
        tr = read_trace_csv(f)
    except TraceError:
        return
    assert len(tr) >= 2 and np.all(np.diff(tr.t) > 0)
    assert np.all(np.isfinite(tr.lat)) and np.all(np.abs(tr.lat) <= 90)


@SETTINGS
@given(st.floats(-89.9, 89.9), st.floats(-180, 180),
       st.floats(-5000, 5000), st.floats(-5000, 5000))
def test_metres_degrees_round_trip(lat, lon, north, east):
    lat2, lon2 = offset(lat, lon, north, east)
    n, e = difference(lat2, lon2, lat, lon)
    assert abs(float(n) - north) < 1e-6 and abs(float(e) - east) < 1e-6

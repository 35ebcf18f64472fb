"""
Zone maps (GeoJSON) and errors that follow the zone.

The map's rules, its errors, and the statistics of a walk through two zones
(DS1 then DS5).
"""

import json

import numpy as np
import pytest
import yaml

from gps_error_ros.model import streams
from gps_error_ros.model.profiles import builtin_dir, load_profile, profile_from_dict
from gps_error_ros.model.stepping import state_at, StepsPerFix
from gps_error_ros.model.zoned import simulate_along, WithZones, zoned_errors
from gps_error_ros.model.zones import load_zone_map, OUTSIDE, zone_models, ZoneMapError

LAT0, LON0 = 40.75, -73.99


def square(lon0, lat0, size):
    """Return a GeoJSON Polygon: a square of ``size`` degrees at (lon0, lat0)."""
    ring = [[lon0, lat0], [lon0 + size, lat0], [lon0 + size, lat0 + size],
            [lon0, lat0 + size], [lon0, lat0]]
    return {'type': 'Polygon', 'coordinates': [ring]}


def feature(geometry, **props):
    """Return a GeoJSON Feature."""
    return {'type': 'Feature', 'properties': props, 'geometry': geometry}


def write_map(path, features, **extra):
    """Write a FeatureCollection; return its path."""
    path.write_text(json.dumps({'type': 'FeatureCollection', 'features': features,
                                **extra}))
    return path


def two_zones(tmp_path, **extra):
    """West square DS1 (ninth), east square DS5 (seventh), touching at LON0 + 0.01."""
    return write_map(tmp_path / 'zones.geojson', [
        feature(square(LON0, LAT0, 0.01), name='ninth', profile='DS1'),
        feature(square(LON0 + 0.01, LAT0, 0.01), name='seventh', profile='DS5')], **extra)


def test_lookup_edges_overlaps_and_outside(tmp_path):
    big = square(LON0, LAT0, 0.02)
    path = write_map(tmp_path / 'm.geojson', [
        feature(square(LON0 + 0.005, LAT0 + 0.005, 0.005), name='inner', profile='DS5'),
        feature(big, name='outer', profile='DS1')])
    zmap = load_zone_map(path)
    assert zmap.names == ['inner', 'outer'] and len(zmap) == 2
    lat = np.array([LAT0 + 0.007, LAT0 + 0.001, LAT0 + 0.03, LAT0, np.nan])
    lon = np.array([LON0 + 0.007, LON0 + 0.001, LON0 + 0.001, LON0 + 0.01, LON0])
    # overlap: the first feature in the file; an edge counts as inside;
    # outside (and a non-finite position) is the default
    assert zmap.lookup(lat, lon).tolist() == [0, 1, OUTSIDE, 1, OUTSIDE]
    assert [p.name for p in zmap.profiles] == ['DS5', 'DS1'] and zmap.default is None


def test_profiles_relative_to_the_map_and_default(tmp_path):
    sub = tmp_path / 'profiles'
    sub.mkdir()
    (sub / 'mine.yaml').write_text((builtin_dir() / 'DS2.yaml').read_text())
    path = write_map(tmp_path / 'm.geojson',
                     [feature(square(LON0, LAT0, 0.01), profile='profiles/mine.yaml')],
                     default_profile='DS7')
    zmap = load_zone_map(path)
    assert zmap.names == ['zone0'] and zmap.profiles[0].name == 'DS2'
    default, models = zone_models(zmap, load_profile('DS1'))
    assert default.name == 'DS7' and len(models) == 2     # the zone, then the default


@pytest.mark.parametrize('content, expected', [
    ('{"type": "FeatureCollection", "features": [', 'not valid JSON (line 1'),
    ({'type': 'Feature'}, 'expected a GeoJSON FeatureCollection'),
    ({'type': 'FeatureCollection', 'features': []}, 'expected a non-empty list'),
    ({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'name': 'a'},
         'geometry': square(LON0, LAT0, .01)}]},
     'feature 0 (a): expected a property "profile"'),
    ({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'profile': 'DS9'},
         'geometry': square(LON0, LAT0, .01)}]},
     "feature 0 (zone0): unknown profile 'DS9'"),
    ({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'profile': 'DS3'},
         'geometry': square(LON0, LAT0, .01)}]},
     'has no fitted AR parameters'),
    ({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'profile': 'DS1'},
         'geometry': {'type': 'Point', 'coordinates': [LON0, LAT0]}}]},
     'expected a GeoJSON Polygon or MultiPolygon'),
    ({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'profile': 'DS1'},
         'geometry': square(LAT0, LON0 - 30, 1)}]},
     'expected WGS84 [longitude, latitude]'),
    ({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'profile': 'DS1'}, 'geometry': {
            'type': 'Polygon', 'coordinates': [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]}}]},
     'the polygon is not valid (Self-intersection'),
    ({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'profile': 'DS1', 'name': 'x'},
         'geometry': square(0, 0, 1)},
        {'type': 'Feature', 'properties': {'profile': 'DS5', 'name': 'x'},
         'geometry': square(2, 0, 1)}]},
     "expected unique names, got ['x']"),
])
def test_bad_maps_say_what_and_where(tmp_path, content, expected):
    path = tmp_path / 'bad.geojson'
    path.write_text(content if isinstance(content, str) else json.dumps(content))
    with pytest.raises(ZoneMapError) as exc:
        load_zone_map(path)
    assert str(path) in str(exc.value) and expected in str(exc.value), str(exc.value)


def test_zone_profiles_that_cannot_mix_with_the_default(tmp_path):
    text = (builtin_dir() / 'DS2.yaml').read_text()
    (tmp_path / 'lag.yaml').write_text(text + 'effects:\n  motion_lag: {lag_s: 0.5}\n')
    (tmp_path / 'fast.yaml').write_text(text.replace('rate_hz: 1.0', 'rate_hz: 2.0'))
    (tmp_path / 'outages.yaml').write_text(
        text + 'availability: {outage_rate: 0.01, durations: [[2, 0.5], [5, 0.5]]}\n')
    (tmp_path / 'fails.yaml').write_text(text + 'gross_failures: {rate: 0.01, sizes_m: [90]}\n')
    (tmp_path / 'crowd.yaml').write_text(text + 'population: {bias_sd_m: [1, 1], '
                                                'scale_sd_log: 0.1}\n')
    for name, expected in (('lag', 'motion_lag 0.5 s differs'),
                           ('fast', 'rate_hz 2.0 differs'),
                           ('outages', 'has an availability section'),
                           ('fails', 'has a gross_failures section; expected none'),
                           ('crowd', 'has a population section; expected none')):
        path = write_map(tmp_path / f'{name}.geojson',
                         [feature(square(LON0, LAT0, 0.01), profile=f'{name}.yaml')])
        with pytest.raises(ZoneMapError, match=expected):
            zone_models(load_zone_map(path), load_profile('DS1'))


def test_the_default_profiles_failures_serve_every_zone(tmp_path):
    """Failures come from the default profile, at the same steps and sizes in every zone."""
    text = (builtin_dir() / 'DS5.yaml').read_text()
    (tmp_path / 'fails.yaml').write_text(text + 'gross_failures: {rate: 0.2, sizes_m: [90]}\n')
    path = two_zones(tmp_path, default_profile=str(tmp_path / 'fails.yaml'))
    default, model, (zone_map, zoned) = zoned_errors(load_zone_map(path), load_profile('DS1'))
    assert default.gross_failures is not None
    keys = streams.agent_keys(4, [f'a{i}' for i in range(6)])
    zoned.grow(keys.size)
    zoned.restart(0)
    rows = np.arange(keys.size)
    zones = np.array([0, 1, OUTSIDE, 0, 1, OUTSIDE])
    got = np.array([zoned.errors(rows, keys, k, zones)[0] for k in range(300)])
    failed = np.isclose(np.hypot(*got.T).T, 90.0, atol=1e-9)
    alone = model.simulate(keys, 300)           # the default's failures, no zones
    np.testing.assert_array_equal(failed, np.isclose(np.hypot(*alone.T).T, 90.0, atol=1e-9))
    np.testing.assert_allclose(got[failed], alone[failed], atol=1e-9)
    assert 0.1 < failed.mean() < 0.3
    # where no fix failed, DS5's process outside the zones runs on beneath the failures
    np.testing.assert_allclose(got[~failed[:, 2], 2], alone[~failed[:, 2], 2], atol=1e-9)


def _population_profile(tmp_path, section):
    """Write DS5 with a population section; return its path."""
    path = tmp_path / 'crowd.yaml'
    path.write_text((builtin_dir() / 'DS5.yaml').read_text() + f'population: {section}\n')
    return path


def test_the_default_profiles_population_serves_every_zone(tmp_path):
    """Outside the zones an agent is the default profile's; in them it keeps its bias."""
    crowd = _population_profile(tmp_path, '{bias_sd_m: [3, 4], scale_sd_log: 0.3, '
                                          'bias_time_constant_s: 50, bias_dof: 4, '
                                          'run_bias_sd_m: [2, 5]}')
    path = two_zones(tmp_path, default_profile=str(crowd))
    for mode, about in (('stationary', False), ('conditional', False),
                        ('stationary', True), ('conditional', True)):
        default, model, (_, zoned) = zoned_errors(load_zone_map(path), load_profile('DS1'),
                                                  mode, about_truth=about)
        keys = streams.agent_keys(4, [f'a{i}' for i in range(6)])
        zoned.grow(keys.size)
        zoned.restart(0)
        got = [zoned.errors(np.arange(6), keys, k, np.full(6, OUTSIDE)) for k in range(300)]
        np.testing.assert_allclose(np.array([e for e, _ in got]), model.simulate(keys, 300),
                                   atol=1e-9)
        for k in (0, 1, 57, 299):
            expected = state_at(model, keys, 0, k, cov=True)[1] if mode == 'conditional' else \
                np.broadcast_to(model.stationary_cov, (6, 2, 2))
            np.testing.assert_allclose(got[k][1], expected, atol=1e-9)
    # a bias of 20 m and one scale: an agent's mean error is its bias in both zones
    crowd = _population_profile(tmp_path, '{bias_sd_m: [20, 20], scale_sd_log: 0.0}')
    default, _, (zmap, zoned) = zoned_errors(load_zone_map(path), load_profile(str(crowd)))
    n = 400
    keys = streams.agent_keys(7, [f'p{i}' for i in range(n)])
    zoned.grow(n)
    zoned.restart(0)
    lat = np.full(n, LAT0 + 0.005)
    out = np.array([zoned.errors(np.arange(n), keys, k, zmap.lookup(
        lat, np.full(n, LON0 + (0.005 if k < 300 else 0.015))))[0] for k in range(600)])
    means = [out[100:300].mean(axis=0) - zmap.profiles[0].model().mean,
             out[400:].mean(axis=0) - zmap.profiles[1].model().mean]
    for axis in (0, 1):
        assert np.corrcoef(means[0][:, axis], means[1][:, axis])[0, 1] > 0.95
        assert 17 < means[0][:, axis].std() < 23
    # stated (stationary mode): the zone's stationary covariance and the bias spread
    cov = zoned.errors(np.arange(n), keys, 600, zmap.lookup(lat, np.full(n, LON0 + 0.005)))[1]
    np.testing.assert_allclose(cov, np.broadcast_to(
        zmap.profiles[0].model().stationary_cov + 400 * np.eye(2), (n, 2, 2)))


def test_one_zone_is_the_plain_model():
    model = load_profile('DS5').model()
    keys = streams.agent_keys(3, ['a', 'b', 'c'])
    zoned = StepsPerFix(WithZones([load_profile('DS5').process(),
                                   load_profile('DS1').process()]), 3)
    zoned.restart(10)
    got = np.array([zoned.errors(np.arange(3), keys, k, np.zeros(3, int))[0]
                    for k in range(10, 60)])
    np.testing.assert_allclose(got, model.simulate(keys, 50, start=10), atol=1e-9)


REGIMES = {'variance_regimes': {'scales': [1.0, 3.0], 'transition': [[0.9, 0.1], [0.3, 0.7]]}}


@pytest.mark.parametrize('street', [False, True], ids=['regimes', 'regimes in a street frame'])
def test_what_a_covariance_is_about_does_not_change_the_errors_in_zones(street):
    """
    The regime chain runs on beneath covariances stated about the truth.

    (The zone path once read a model stating its covariances about the truth
    as one without regimes, and restarted the chain from regime 0 each step.)
    """
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['effects'] = dict(REGIMES, **({'street_frame': {'sigma_along': 0.6,
                                                        'sigma_across': 1.4}}
                                      if street else {}))
    profile = profile_from_dict(raw, 'regimes')
    keys = streams.agent_keys(3, [f'r{i}' for i in range(20)])
    got = []
    for about in (False, True):
        zoned = StepsPerFix(profile.model(about_truth=about), conditional_cov=True)
        got.append(simulate_along(zoned, keys, np.arange(300), np.full(300, OUTSIDE)))
    np.testing.assert_array_equal(got[0], got[1])
    if not street:          # and they are the model's own, with or without a zone map
        np.testing.assert_allclose(got[0], profile.model().simulate(keys, 300), atol=1e-9)


def _acf(x, mean, lags):
    """Return the autocorrelation per axis of x (time, agents, 2) about a known mean."""
    d = x - mean
    var = (d * d).mean(axis=(0, 1))
    return np.array([(d[lag:] * d[:len(d) - lag]).mean(axis=(0, 1)) / var for lag in lags])


def test_walk_through_two_zones_has_each_zones_statistics(tmp_path):
    """
    Walk 600 s in DS1's zone, then 600 s in DS5's (500 walkers).

    In the last 300 s of each zone the SD and the ACF are that zone's
    model's, and the step at the crossing is no larger than the steps inside
    the zones.

    Tolerances: the windows hold about 500 x 300 / 30 = 5,000 independent
    samples (correlation times up to ~30 s), so the SD is known to ~1 % and
    the ACF to ~0.02; the bounds are 7 % and 0.06.
    """
    zmap = load_zone_map(two_zones(tmp_path))
    default, model, (zmap, zoned) = zoned_errors(zmap, load_profile('DS2'))
    n, half = 500, 600
    keys = streams.agent_keys(11, [f'p{i}' for i in range(n)])
    zoned.grow(n)
    zoned.restart(0)
    lat = np.full(n, LAT0 + 0.005)
    out = np.empty((2 * half, n, 2))
    for k in range(2 * half):
        lon = np.full(n, LON0 + (0.005 if k < half else 0.015))
        out[k] = zoned.errors(np.arange(n), keys, k, zmap.lookup(lat, lon))[0]
    lags = (1, 5, 10)
    for z, window in ((0, slice(half - 300, half)), (1, slice(2 * half - 300, None))):
        exact = zmap.profiles[z].model()
        x = out[window]
        sd = x.std(axis=(0, 1))
        assert np.all(np.abs(sd / exact.stationary_sd - 1) < 0.07), (z, sd)
        acf = _acf(x, exact.mean, lags)
        assert np.all(np.abs(acf - exact.autocorrelation(10)[list(lags)]) < 0.06), (z, acf)
    step = np.hypot(*np.diff(out, axis=0).transpose(2, 0, 1))     # (time, agents)
    rms = {name: float(np.sqrt(np.mean(step[w] ** 2))) for name, w in (
        ('ninth', slice(half - 300, half - 1)), ('crossing', half - 1),
        ('seventh', slice(2 * half - 300, None)))}
    assert rms['crossing'] <= 1.15 * max(rms['ninth'], rms['seventh']), rms


WANDERING = '{bias_sd_m: [2, 3], scale_sd_log: 0.4, bias_time_constant_s: 30}'
TWO_SCALES = '{bias_sd_m: [2, 3], scale_sd_log: 0.4, bias_time_constant_s: 30, ' \
    'run_bias_sd_m: [4, 1]}'


@pytest.mark.parametrize('population', [None, WANDERING, TWO_SCALES])
def test_an_agents_errors_do_not_depend_on_who_else_is_served(tmp_path, population):
    """Shards, late starts and the order agents are served in change nothing."""
    zmap = load_zone_map(two_zones(tmp_path))
    profile = load_profile('DS2') if population is None else \
        load_profile(str(_population_profile(tmp_path, population)))
    _, _, (_, whole) = zoned_errors(zmap, profile, 'conditional')
    _, _, (_, shard) = zoned_errors(zmap, profile, 'conditional')
    names = [f'p{i}' for i in range(6)]
    keys = streams.agent_keys(5, names)
    whole.grow(6)
    shard.grow(2)
    whole.restart(100)
    shard.restart(100)
    lat = np.full(6, LAT0 + 0.005)
    rng = np.random.default_rng(0)
    for k in range(100, 160):
        # each walker crosses at its own time; p5 gets its first fix at step
        # 130 (a later attach: caught up in its zone then); the whole crowd
        # is served in a shuffled order, the shard serves p4 and p5 only
        lon = LON0 + 0.0095 + 1e-4 * (k - 100) * np.arange(1, 7) / 6
        zones = zmap.lookup(lat, lon)
        served = np.arange(6 if k >= 130 else 5)
        order = rng.permutation(served)
        e_all, c_all = np.empty((6, 2)), np.empty((6, 2, 2))
        e_all[order], c_all[order] = whole.errors(order, keys[order], k, zones[order])
        rows = served[4:] - 4
        e, c = shard.errors(rows, keys[4 + rows], k, zones[4 + rows])
        np.testing.assert_allclose(e, e_all[4 + rows], rtol=0, atol=1e-9)
        np.testing.assert_allclose(c, c_all[4 + rows], rtol=0, atol=1e-9)
    assert set(zones.tolist()) == {1}        # everyone ended in the east zone


def test_lookup_agrees_with_shapely_point_by_point():
    """The cell index gives what a plain test of every point against every polygon gives."""
    import shapely
    from gps_error_ros.model.zones import ZoneMap
    rng = np.random.default_rng(4)
    polys = []
    for _ in range(30):                 # overlapping stars of 5-9 points, one with a hole
        c = rng.uniform(0, 1, 2)
        k = rng.integers(5, 10)
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        r = rng.uniform(0.02, 0.2, k)
        polys.append(shapely.Polygon(np.c_[c[0] + r * np.cos(ang), c[1] + r * np.sin(ang)]))
    polys.append(shapely.box(0.3, 0.3, 0.7, 0.7).difference(shapely.box(0.4, 0.4, 0.6, 0.6)))
    prof = load_profile('DS5')
    zmap = ZoneMap(polys, [f'z{i}' for i in range(len(polys))], [prof] * len(polys))
    x, y = rng.uniform(-0.2, 1.2, 5000), rng.uniform(-0.2, 1.2, 5000)
    x[:3], y[:3] = 0.3, 0.5                   # on an edge of the holed box: inside
    want = np.full(x.size, OUTSIDE)
    for i in range(len(polys) - 1, -1, -1):   # the first feature wins an overlap
        want[shapely.intersects_xy(polys[i], x, y)] = i
    np.testing.assert_array_equal(zmap.lookup(y, x), want)
    assert (want != OUTSIDE).sum() > 1000 and (want == OUTSIDE).sum() > 1000


def test_the_shipped_example_map_covers_the_demo_walk():
    """config/zones/midtown-pixel.geojson: the demo's walker meets both avenues' zones."""
    from pathlib import Path
    from gps_error_ros.model.geodesy import offset
    from gps_error_ros.sim.walker import MANHATTAN_DATUM, manhattan_walk
    path = Path(__file__).resolve().parents[2] / 'config' / 'zones' / 'midtown-pixel.geojson'
    zmap = load_zone_map(path)
    assert zmap.names == ['7th Avenue', '9th Avenue'] and zmap.default.name == 'DS5'
    assert [p.name for p in zmap.profiles] == ['DS5', 'DS2']
    walk = manhattan_walk(7200.0, np.random.default_rng(3))
    t = np.arange(0.0, walk.duration, 5.0)
    east, north = walk.position(t)
    lat, lon = offset(MANHATTAN_DATUM[0], MANHATTAN_DATUM[1], north, east)
    zones = zmap.lookup(lat, lon)
    shares = [(zones == z).mean() for z in (0, 1)]
    assert min(shares) > 0.05, shares
    assert set(np.unique(zones)) <= {0, 1, OUTSIDE}

"""Per-zone calibration (``calibrate --zones``) on a rosbag2 and on a CSV."""

import json
import subprocess
import sys

import numpy as np
import pytest

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.model.zones import load_zone_map, zone_models
from gps_error_ros.model.profiles import load_profile
from bag_helpers import write_walk_bag

DATUM = (52.52, 13.40, 40.0)
SPEED = (0.8, 0.6)                  # east, north m/s: write_walk_bag's walk
A = (AxisParams(0.4, (1.2, -0.35), 0.5), AxisParams(-0.2, (0.85, 0.0), 0.8))
B = (AxisParams(-1.0, (0.6, 0.2), 2.0), AxisParams(0.5, (1.5, -0.6), 1.2))
N = 2000                            # samples in each zone


def box(frame, e0, e1):
    """Return a GeoJSON Polygon spanning east e0..e1 m, north -1..5 km, of the frame."""
    corners = [(e0, -1000.0), (e1, -1000.0), (e1, 5000.0), (e0, 5000.0), (e0, -1000.0)]
    ring = []
    for e, n in corners:
        lat, lon, _ = frame.to_geodetic(e, n, 0.0)
        ring.append([float(lon), float(lat)])
    return {'type': 'Polygon', 'coordinates': [ring]}


def yw_se(params, n):
    """Return the asymptotic SE of Yule-Walker phi: sqrt(diag(s2 G^-1)/n)."""
    model = ARErrorModel(params, params)
    acv = model.autocovariance(params.order)[:, 0, 0]
    p = params.order
    gamma = np.array([[acv[abs(i - j)] for j in range(p)] for i in range(p)])
    return np.sqrt(np.diag(params.sigma_w ** 2 * np.linalg.inv(gamma)) / n)


def test_a_profile_per_zone_from_a_bag(tmp_path):
    """
    A walk whose errors change process where it crosses from zone west to east.

    Each zone's fit recovers its own process (phi within 5 SE, sigma_w within
    5 SE), a zone the walk never enters keeps the fallback and says why, and
    what is written loads and runs.
    """
    err = np.concatenate([ARErrorModel(*A).simulate(streams.agent_key(5), N)[:, 0],
                          ARErrorModel(*B).simulate(streams.agent_key(6), N)[:, 0]])
    jitter = np.random.default_rng(1).uniform(-0.05, 0.05, 2 * N)
    fix_t = 1000.0 + np.arange(2 * N) + jitter
    bag = tmp_path / 'walk'
    write_walk_bag(bag, 'mcap', DATUM, err, fix_t)
    frame = LocalTangentFrame(*DATUM)
    border = SPEED[0] * (1000.0 + N - 0.5)          # between the two processes
    zones = tmp_path / 'zones.geojson'
    zones.write_text(json.dumps({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'name': 'west', 'profile': 'DS1'},
         'geometry': box(frame, 0.0, border)},
        {'type': 'Feature', 'properties': {'name': 'east', 'profile': 'DS1'},
         'geometry': box(frame, border, 10000.0)},
        {'type': 'Feature', 'properties': {'name': 'never visited', 'profile': 'DS1'},
         'geometry': box(frame, -3000.0, -2000.0)}]}))
    out = tmp_path / 'profiles'
    r = subprocess.run([sys.executable, '-m', 'gps_error_ros.cli', 'calibrate', str(bag),
                        '--zones', str(zones), '-o', str(out), '--truth-topic', '/truth',
                        '--datum', ','.join(map(str, DATUM)), '--order', '2'],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert 'never visited: fallback all.yaml (0 samples, fewer than 300)' in r.stdout, r.stdout
    zmap = load_zone_map(out / 'zones.geojson')
    assert zmap.names == ['west', 'east', 'never visited']
    assert zmap.default.name == 'walk-all' and zmap.profiles[2].name == 'walk-all'
    for z, true in ((0, A), (1, B)):
        p = zmap.profiles[z]
        assert p.fit['samples'] == N and p.fit['segments'] == 1, p.fit
        for axis, params in zip(('north', 'east'), true):
            got = p.axes[axis]
            assert np.all(np.abs(np.array(got.phi) - params.phi) < 5 * yw_se(params, N)), \
                (z, axis, got)
            assert abs(got.sigma_w - params.sigma_w) < 5 * params.sigma_w / np.sqrt(2 * N)
    default, models = zone_models(zmap, load_profile('DS5'))
    assert default.name == 'walk-all' and len(models) == 4


def test_a_file_where_a_directory_is_expected(tmp_path):
    from gps_error_ros.cli import main as gps_error
    zones = tmp_path / 'zones.geojson'
    zones.write_text('{}')
    out = tmp_path / 'profile.yaml'
    out.write_text('x')
    assert gps_error(['calibrate', str(tmp_path / 'missing.csv'), '--zones', str(zones),
                      '-o', str(out)]) == 2
    assert out.read_text() == 'x'


def test_population_with_zones_is_refused_not_ignored(tmp_path, capsys):
    from gps_error_ros.cli import main as gps_error
    zones = tmp_path / 'zones.geojson'
    zones.write_text('{}')
    out = tmp_path / 'profiles'
    assert gps_error(['calibrate', str(tmp_path / 'missing.csv'), '--zones', str(zones),
                      '--population', '-o', str(out)]) == 2
    assert '--population with --zones' in capsys.readouterr().err and not out.exists()


@pytest.mark.parametrize('bad', ['{"type": "Feature"}', '{'])
def test_a_bad_map_fails_before_anything_is_written(tmp_path, bad, capsys):
    from gps_error_ros.cli import main as gps_error
    zones = tmp_path / 'zones.geojson'
    zones.write_text(bad)
    out = tmp_path / 'profiles'
    assert gps_error(['calibrate', str(tmp_path / 'missing.csv'), '--zones', str(zones),
                      '-o', str(out)]) == 2
    assert str(zones) in capsys.readouterr().err and not out.exists()


def test_a_profile_per_zone_from_a_csv(tmp_path):
    """
    Round trip through the simulator: DS1's zone then DS5's, 3,000 s in each.

    The walk is simulated with the zone map (``simulate --zones``) and
    calibrated back per zone: each zone's fitted stationary SD is its
    profile's within 30 % (3,000 samples with correlation times up to ~30 s
    hold ~100 independent ones: a relative SE of ~7 %).
    """
    from gps_error_ros.cli import main as gps_error
    frame = LocalTangentFrame(*DATUM)
    speed, n = 1.0, 3000
    zones = tmp_path / 'zones.geojson'
    zones.write_text(json.dumps({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'name': 'ninth', 'profile': 'DS1'},
         'geometry': box(frame, -10.0, speed * (n - 0.5))},
        {'type': 'Feature', 'properties': {'name': 'seventh', 'profile': 'DS5'},
         'geometry': box(frame, speed * (n - 0.5), 10000.0)}]}))
    truth = tmp_path / 'truth.csv'
    lat, lon, _ = frame.to_geodetic(speed * np.arange(2 * n), np.zeros(2 * n),
                                    np.zeros(2 * n))
    with open(truth, 'w') as f:
        f.write('t,truth_lat,truth_lon\n')
        for k in range(2 * n):
            f.write(f'{k},{lat[k]:.9f},{lon[k]:.9f}\n')
    trace = tmp_path / 'walk.csv'
    assert gps_error(['simulate', '--profile', 'DS2', '--seed', '3', '--zones', str(zones),
                      '--trajectories', str(truth), '--out', str(trace)]) == 0
    out = tmp_path / 'profiles'
    assert gps_error(['calibrate', str(trace), '--zones', str(zones), '-o', str(out),
                      '--order', '3']) == 0
    zmap = load_zone_map(out / 'zones.geojson')
    for z, name in enumerate(('DS1', 'DS5')):
        fitted = zmap.profiles[z].model().stationary_sd
        true = load_profile(name).model().stationary_sd
        assert np.all(np.abs(fitted / true - 1) < 0.3), (name, fitted, true)
        assert zmap.profiles[z].fit['samples'] >= n - 1


def test_compare_zones_finds_the_gain_where_there_is_one(tmp_path):
    """
    A walk back and forth between DS1's zone and DS5's, 4,000 s.

    Both parts of the split visit both zones, so ``compare --zones`` must
    find that a profile per zone predicts the held-out part better than one
    profile, beyond sampling (the interval of the gain above zero), and
    report every zone.
    """
    from gps_error_ros.cli import main as gps_error
    frame = LocalTangentFrame(*DATUM)
    zones = tmp_path / 'zones.geojson'
    zones.write_text(json.dumps({'type': 'FeatureCollection', 'features': [
        {'type': 'Feature', 'properties': {'name': 'ninth', 'profile': 'DS1'},
         'geometry': box(frame, -1000.0, 0.0)},
        {'type': 'Feature', 'properties': {'name': 'seventh', 'profile': 'DS5'},
         'geometry': box(frame, 0.0, 1000.0)}]}))
    k = np.arange(4000)
    east = 400.0 * np.sin(2 * np.pi * k / 800.0) + 0.3      # 400 s each side
    lat, lon, _ = frame.to_geodetic(east, np.zeros(k.size), np.zeros(k.size))
    truth = tmp_path / 'truth.csv'
    with open(truth, 'w') as f:
        f.write('t,truth_lat,truth_lon\n')
        for i in k:
            f.write(f'{i},{lat[i]:.9f},{lon[i]:.9f}\n')
    trace = tmp_path / 'walk.csv'
    assert gps_error(['simulate', '--profile', 'DS2', '--seed', '8', '--zones', str(zones),
                      '--trajectories', str(truth), '--out', str(trace)]) == 0
    out = tmp_path / 'compare.json'
    assert gps_error(['compare', str(trace), '--zones', str(zones), '--sims', '40',
                      '--json', str(out)]) == 0
    z = json.loads(out.read_text())['zones']
    assert set(z['classes']) == {'one_profile', 'per_zone'}
    assert z['nll_improvement']['ci95'][0] > 0.0, z['nll_improvement']
    assert z['classes']['per_zone']['heldout_nll_per_sample'] < \
        z['classes']['one_profile']['heldout_nll_per_sample']
    for name in ('ninth', 'seventh'):
        assert z['zones'][name]['fitted'] and z['zones'][name]['heldout_samples'] > 300, z


def test_validate_zones_checks_each_zone_alone(tmp_path):
    """
    The walk of the CSV test validated with its own zone map, and swapped.

    With the right map each zone's measured SD lies inside its simulated
    range; with DS1 and DS5 swapped it lies outside in both zones.
    """
    from gps_error_ros.cli import main as gps_error
    frame = LocalTangentFrame(*DATUM)
    n = 2000
    lat, lon, _ = frame.to_geodetic(np.arange(2 * n, dtype=float), np.zeros(2 * n),
                                    np.zeros(2 * n))
    truth = tmp_path / 'truth.csv'
    with open(truth, 'w') as f:
        f.write('t,truth_lat,truth_lon\n')
        for k in range(2 * n):
            f.write(f'{k},{lat[k]:.9f},{lon[k]:.9f}\n')
    sd = {}
    for label, (west, east) in (('right', ('DS1', 'DS5')), ('swapped', ('DS5', 'DS1'))):
        zones = tmp_path / f'{label}.geojson'
        zones.write_text(json.dumps({'type': 'FeatureCollection', 'features': [
            {'type': 'Feature', 'properties': {'name': 'ninth', 'profile': west},
             'geometry': box(frame, -10.0, n - 0.5)},
            {'type': 'Feature', 'properties': {'name': 'seventh', 'profile': east},
             'geometry': box(frame, n - 0.5, 10000.0)}]}))
        if label == 'right':
            trace = tmp_path / 'walk.csv'
            assert gps_error(['simulate', '--profile', 'DS2', '--seed', '4', '--zones',
                              str(zones), '--trajectories', str(truth), '--out',
                              str(trace)]) == 0
        out = tmp_path / label
        assert gps_error(['validate', 'DS2', str(trace), '--zones', str(zones), '--out',
                          str(out), '--sims', '60']) == 0
        sd[label] = json.loads((out / 'validation.json').read_text())['zones']
    for zone in ('ninth', 'seventh'):
        for ax in ('north', 'east'):
            right, swapped = sd['right'][zone][ax], sd['swapped'][zone][ax]
            lo, _, hi = right['sd_simulated_m']
            assert lo <= right['sd_m'] <= hi, (zone, ax, right)
            lo, _, hi = swapped['sd_simulated_m']
            assert not lo <= swapped['sd_m'] <= hi, (zone, ax, swapped)

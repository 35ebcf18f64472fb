"""
One stepping loop: every path gives an agent the same errors, for every profile the schema takes.

Profiles are drawn (hypothesis) from the whole schema: AR orders 1-5, any
subset of the effects (street_frame and cross_axis_coupling exclude each
other), with and without a population, availability, gross failures,
velocity, stated accuracy and a zone map. Each draw runs every path that
takes a trajectory on a walk that turns corners and stands: ``add_errors``,
``gps_error simulate`` to CSV, to FCD and to FCD as Parquet, and the node's engine
(:class:`~gps_error_ros.sim.engine.FixEngine`, fed as the node feeds it).
Their errors agree to 1e-9 m (the engine's and the trajectory path's, which
``simulate`` writes), and their positions, which are degrees, to 1e-8 m
(about ten units in the last place of a latitude). A draw with nothing that depends on
motion (no street frame, no motion lag, no zones) also runs the paths that
take no trajectory (``simulate_errors``, ``model.simulate``) against a walk
due north.
"""

import contextlib
import io
import json
import math
import os
import tempfile

import numpy as np
import pytest
import yaml
from hypothesis import given, HealthCheck, Phase, settings, strategies as st

import gps_error_ros as ge
from gps_error_ros.cli import main as gps_error
from gps_error_ros.model.effect_kinds import KINDS
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.model.profiles import builtin_dir, load_profile, profile_from_dict
from gps_error_ros.model.streams import agent_keys
from gps_error_ros.sim.engine import FixEngine
from gps_error_ros.sim.trajectory_fixes import trajectory_fixes

NS = 1_000_000_000
LAT0, LON0 = 40.75057, -73.99065
T0, STEPS = 1000.0, 150
AGENTS = ['ann', 'bob']
TOL_M = 1e-9
#: Positions are degrees: one unit in the last place of a latitude near 40 is ~0.8 nm, and
#: a motion lag's truth is interpolated by the engine and by simulate in their own order.
POS_M = 1e-8
M_PER_DEG = 111_320.0
PRESET = yaml.safe_load((builtin_dir() / 'phone-suburban-drive.yaml').read_text())


def phi_from_pacf(pacf):
    """Return stationary AR coefficients from partial autocorrelations (Durbin-Levinson)."""
    phi = []
    for r in pacf:
        phi = [p - r * q for p, q in zip(phi, reversed(phi))] + [r]
    return phi


axis = st.builds(lambda pacf, delta, sw: {'delta': delta, 'phi': phi_from_pacf(pacf),
                                          'sigma_w': sw},
                 st.integers(1, 5).flatmap(lambda p: st.lists(
                     st.floats(-0.85, 0.95), min_size=p, max_size=p)),
                 st.floats(-1.0, 1.0), st.floats(0.2, 3.0))

EFFECTS = {
    'cross_axis_coupling': st.builds(lambda c: {'innovation_corr': c}, st.floats(-0.6, 0.6)),
    'motion_lag': st.builds(lambda s: {'lag_s': s}, st.floats(0.3, 2.0)),
    'heavy_tails': st.builds(lambda d: {'dof': d}, st.floats(3.0, 12.0)),
    'variance_regimes': st.builds(
        lambda s, a, b: {'scales': [1.0, s], 'transition': [[1 - a, a], [b, 1 - b]]},
        st.floats(1.5, 4.0), st.floats(0.02, 0.3), st.floats(0.05, 0.5)),
    'street_frame': st.builds(lambda a, c: {'sigma_along': a, 'sigma_across': c},
                              st.floats(0.2, 2.0), st.floats(0.2, 3.0)),
    'periodic': st.integers(2, 6).flatmap(lambda n: st.builds(
        lambda sc, off: {'period_steps': n, 'scales': sc,
                         'offsets': (np.array(off) - np.mean(off, axis=0)).tolist()},
        st.lists(st.floats(0.5, 1.5), min_size=n, max_size=n),
        st.lists(st.lists(st.floats(-1.0, 1.0), min_size=2, max_size=2),
                 min_size=n, max_size=n))),
    'outliers': st.builds(lambda r, m, s: {'rate': r, 'mean_steps': m, 'sigma_m': s},
                          st.floats(0.01, 0.1), st.floats(1.0, 5.0), st.floats(3.0, 30.0)),
}


@st.composite
def effects(draw):
    names = draw(st.sets(st.sampled_from(sorted(EFFECTS))))
    if {'street_frame', 'cross_axis_coupling'} <= names:
        names.discard(draw(st.sampled_from(['street_frame', 'cross_axis_coupling'])))
    return {n: draw(EFFECTS[n]) for n in sorted(names)}


SECTIONS = {
    'population': st.builds(
        lambda b, s, tau, dof, run: {k: v for k, v in {
            'bias_sd_m': b, 'scale_sd_log': s, 'bias_time_constant_s': tau, 'bias_dof': dof,
            'run_bias_sd_m': run}.items() if v is not None},
        st.lists(st.floats(0.0, 5.0), min_size=2, max_size=2), st.floats(0.0, 0.5),
        st.none() | st.floats(20.0, 600.0), st.none() | st.integers(3, 10),
        st.none() | st.lists(st.floats(0.0, 3.0), min_size=2, max_size=2)),
    'availability': st.builds(lambda r: {'outage_rate': r,
                                         'durations': [[2, 0.5], [5, 0.3], [12, 0.2]]},
                              st.floats(0.01, 0.1)),
    'gross_failures': st.builds(lambda r: {'rate': r, 'sizes_m': [30.0, 80.0, 400.0]},
                                st.floats(0.01, 0.1)),
    'velocity': st.just(PRESET['velocity']),
    'reported_accuracy': st.just(PRESET['reported_accuracy']),
}


@st.composite
def profiles(draw):
    """Return (profile dict, zone profile dict or None) drawn from the whole schema."""
    raw = {'schema': 1, 'name': 'drawn', 'description': 'drawn', 'source': 'hypothesis',
           'rate_hz': 1.0, 'axes': {'north': draw(axis), 'east': draw(axis)}}
    eff = draw(effects())
    if eff:
        raw['effects'] = eff
    for name in sorted(draw(st.sets(st.sampled_from(sorted(SECTIONS))))):
        raw[name] = draw(SECTIONS[name])
    zone = None
    if draw(st.booleans()):
        zone = {'schema': 1, 'name': 'zone', 'description': 'drawn', 'source': 'hypothesis',
                'rate_hz': 1.0, 'axes': {'north': draw(axis), 'east': draw(axis)}}
        zone_eff = draw(effects())
        zone_eff.pop('motion_lag', None)
        if 'motion_lag' in eff:            # a zone has the default's lag
            zone_eff['motion_lag'] = eff['motion_lag']
        if zone_eff:
            zone['effects'] = zone_eff
    return raw, zone


def walk(turning):
    """Return (t, [(east, north) per agent]) of a walk: corners and a stop, or due north."""
    k = np.arange(STEPS, dtype=float)
    if turning:
        east = np.interp(k, [0, 50, 90, 130, 149], [0, 70, 70, 14, 14])
        north = np.interp(k, [0, 50, 90, 130, 149], [0, 0, 56, 56, 56])
    else:
        east, north = np.zeros(STEPS), 1.4 * k
    return T0 + k, [(east, north), (east + 3.0, north - 4.0)]


def rows_of(t, tracks):
    """Return the rows (t, agent, lat, lon) of both agents, sorted together by time."""
    frame = LocalTangentFrame(LAT0, LON0, 0.0)
    lat = np.empty((STEPS, len(AGENTS)))
    lon = np.empty((STEPS, len(AGENTS)))
    for a, (east, north) in enumerate(tracks):
        lat[:, a], lon[:, a], _ = frame.to_geodetic(east, north, np.zeros(STEPS))
    return np.repeat(t, len(AGENTS)), AGENTS * STEPS, lat.reshape(-1), lon.reshape(-1)


def zone_map(folder, zone):
    """Write a zone map whose one zone covers the walk's northern part; return its path."""
    with open(os.path.join(folder, 'zone.yaml'), 'w') as f:
        yaml.safe_dump(zone, f)
    d_lat = 30.0 / M_PER_DEG
    ring = [[LON0 - 0.01, LAT0 + d_lat], [LON0 + 0.01, LAT0 + d_lat],
            [LON0 + 0.01, LAT0 + 0.01], [LON0 - 0.01, LAT0 + 0.01], [LON0 - 0.01, LAT0 + d_lat]]
    path = os.path.join(folder, 'zones.geojson')
    with open(path, 'w') as f:
        json.dump({'type': 'FeatureCollection', 'features': [
            {'type': 'Feature', 'properties': {'name': 'north', 'profile': 'zone.yaml'},
             'geometry': {'type': 'Polygon', 'coordinates': [ring]}}]}, f)
    return path


def engine_fixes(profile, zones, mode, seed, t, lat, lon):
    """Return {(t, agent): (lat, lon, error, fix, cov)} of the node's engine, fed as the node."""
    from gps_error_ros.model.zoned import zoned_errors
    from gps_error_ros.model.zones import load_zone_map
    about = mode != 'reported'
    setup = None
    if zones is None:
        model = profile.model(about_truth=about)
    else:
        profile, model, setup = zoned_errors(load_zone_map(zones), profile, mode, about)
    reported = profile.reported_accuracy if mode == 'reported' else None
    eng = FixEngine(model, agent_keys(seed, AGENTS), rate=1.0, model_rate=profile.rate_hz,
                    start_ns=int(T0 * NS), velocity=profile.velocity,
                    conditional_cov=mode == 'conditional', zones=setup, reported=reported,
                    reported_bias=model.mean if reported is not None else None)
    out = {}
    for i in range(t.size):
        eng.add_truth(i % 2, int(round(t[i] * NS)), float(lat[i]), float(lon[i]), 0.0)
        if i % 2:
            for b in eng.on_clock(int(round(t[i] * NS))):
                cov = np.repeat(np.asarray(model.stationary_cov)[None], b.agents.size, 0) \
                    if b.cov is None else b.cov
                for j, a in enumerate(b.agents):
                    out[(b.stamp_ns / NS, AGENTS[a])] = (b.lat[j], b.lon[j], b.error[j],
                                                         b.fix[j], cov[j])
    return out


def apart_m(lat1, lon1, lat2, lon2):
    """Return the largest distance (m) between two sets of positions (NaN where both are)."""
    both_nan = np.isnan(lat1) & np.isnan(lat2)
    assert np.array_equal(np.isnan(lat1), np.isnan(lat2)), 'a fix on one path, none on another'
    d = np.hypot((lat1 - lat2) * M_PER_DEG,
                 (lon1 - lon2) * M_PER_DEG * math.cos(math.radians(LAT0)))
    return float(np.max(d[~both_nan], initial=0.0))


def write_fcd(path, t, agents, lat, lon):
    with open(path, 'w') as f:
        f.write('<?xml version="1.0" encoding="UTF-8"?>\n<fcd-export>\n')
        for i0 in range(0, t.size, 2):
            f.write(f'  <timestep time="{t[i0]:.2f}">\n')
            for i in (i0, i0 + 1):
                x, y = float(lon[i]), float(lat[i])
                f.write(f'    <person id="{agents[i]}" x="{x!r}" y="{y!r}" '
                        f'angle="0" speed="1.4" pos="0" edge="e" slope="0"/>\n')
            f.write('  </timestep>\n')
        f.write('</fcd-export>\n')


def read_fcd(path):
    import xml.etree.ElementTree as ET
    out = {}
    for ts in ET.parse(path).getroot():
        for p in ts:
            out[(float(ts.get('time')), p.get('id'))] = (float(p.get('y')), float(p.get('x')))
    return out


def run_cli(*argv):
    with contextlib.redirect_stdout(io.StringIO()):
        assert gps_error(['simulate', *argv]) == 0


def check_paths(raw, zone_raw, seed, mode, turning):
    """Run every path on one drawn profile; assert that they agree (see the module doc)."""
    with tempfile.TemporaryDirectory() as folder:
        profile_path = os.path.join(folder, 'drawn.yaml')
        with open(profile_path, 'w') as f:
            yaml.safe_dump(raw, f)
        profile = load_profile(profile_path)
        zones = None if zone_raw is None else zone_map(folder, zone_raw)
        t1, tracks = walk(turning)
        t, agents, lat, lon = rows_of(t1, tracks)
        # add_errors: the library's trajectory path
        fixes = ge.add_errors(profile, t, seed, lat, lon, agents=agents,
                              covariance_mode=mode, zones=zones)
        # gps_error simulate, to a trace CSV and to FCD
        truth = os.path.join(folder, 'truth.csv')
        with open(truth, 'w') as f:
            f.write('t,agent,truth_lat,truth_lon\n')
            for row in zip(t, agents, lat, lon):
                f.write(f'{float(row[0])!r},{row[1]},{float(row[2])!r},{float(row[3])!r}\n')
        common = ['--profile', profile_path, '--seed', str(seed), '--covariance-mode', mode]
        if zones is not None:
            common += ['--zones', zones]
        run_cli('--trajectories', truth, '--out', os.path.join(folder, 'out.csv'), *common)
        import csv
        with open(os.path.join(folder, 'out.csv')) as f:
            table = list(csv.DictReader(f))
        csv_lat = np.array([float(r['lat']) if r['lat'] else np.nan for r in table])
        csv_lon = np.array([float(r['lon']) if r['lon'] else np.nan for r in table])
        assert apart_m(csv_lat, csv_lon, fixes.lat, fixes.lon) <= POS_M
        fcd = os.path.join(folder, 'fcd.xml')
        write_fcd(fcd, t, agents, lat, lon)
        run_cli('--trajectories', fcd, '--out', os.path.join(folder, 'out.xml'),
                '--coordinates', 'lonlat', '--digits', '15', *common)
        moved = read_fcd(os.path.join(folder, 'out.xml'))
        fcd_lat = np.array([moved.get((v, a), (np.nan, np.nan))[0] for v, a in zip(t, agents)])
        fcd_lon = np.array([moved.get((v, a), (np.nan, np.nan))[1] for v, a in zip(t, agents)])
        assert apart_m(fcd_lat, fcd_lon, fixes.lat, fixes.lon) <= POS_M
        # the same FCD as Parquet (SUMO's columns): the errors written to every bit
        import pyarrow as pa
        import pyarrow.parquet as pq
        pq.write_table(pa.table({'timestep_time': t, 'person_id': agents, 'person_x': lon,
                                 'person_y': lat}), os.path.join(folder, 'fcd.parquet'))
        run_cli('--trajectories', os.path.join(folder, 'fcd.parquet'), '--out',
                os.path.join(folder, 'out.parquet'), '--coordinates', 'lonlat', '--errors',
                *common)
        table = pq.read_table(os.path.join(folder, 'out.parquet'))
        by_row = {(r['timestep_time'], r['person_id']): r for r in table.to_pylist()}
        assert len(by_row) == t.size
        got = [by_row[k] for k in zip(t.tolist(), agents)]
        pq_lat = np.array([np.nan if g['person_y'] is None else g['person_y'] for g in got])
        pq_lon = np.array([np.nan if g['person_x'] is None else g['person_x'] for g in got])
        assert apart_m(pq_lat, pq_lon, fixes.lat, fixes.lon) <= POS_M
        np.testing.assert_array_equal([g['fix'] for g in got], fixes.fix)
        # the node's engine; and the errors themselves, where a path gives them
        about = mode != 'reported'
        model = profile.model(about_truth=about)
        setup = None
        if zones is not None:
            from gps_error_ros.model.zoned import zoned_errors
            from gps_error_ros.model.zones import load_zone_map
            _, model, setup = zoned_errors(load_zone_map(zones), profile, mode, about)
        rows, _ = trajectory_fixes({'t': t, 'agent': agents, 'truth_lat': lat,
                                    'truth_lon': lon}, model, profile.rate_hz, seed,
                                   covariance_mode=mode, zones=setup,
                                   reported=profile.reported_accuracy, reported_bias=model.mean)
        served = engine_fixes(profile, zones, mode, seed, t, lat, lon)
        # the node has no fix before its truth reaches a motion lag back (docs/timing.md)
        lag = model.lag_s
        assert {k for k in zip(t, agents) if k not in served} <= \
            {k for k in zip(t, agents) if k[0] < T0 + math.ceil(lag)}
        both = np.array([k in served for k in zip(t, agents)])
        assert both.sum() >= both.size - 2 * math.ceil(lag)
        got = [served[k] for k in zip(t[both], np.array(agents)[both])]
        assert apart_m(np.array([g[0] for g in got]), np.array([g[1] for g in got]),
                       fixes.lat[both], fixes.lon[both]) <= POS_M
        np.testing.assert_allclose(np.array([g[2] for g in got]), rows.error[both], rtol=0,
                                   atol=TOL_M)
        np.testing.assert_array_equal(np.array([g[3] for g in got]), fixes.fix[both])
        if mode == 'conditional':
            np.testing.assert_allclose(np.array([g[4] for g in got]), rows.cov[both], rtol=0,
                                       atol=1e-9)
        if turning:
            return
        # nothing moves the errors: the paths without a trajectory give the same
        errors = ge.simulate_errors(profile, AGENTS, STEPS, seed, start_s=T0,
                                    covariance_mode=mode)
        np.testing.assert_allclose(errors.north_east.transpose(1, 0, 2).reshape(-1, 2),
                                   rows.error, rtol=0, atol=TOL_M)
        np.testing.assert_array_equal(errors.fix.T.reshape(-1), fixes.fix)
        np.testing.assert_array_equal(errors.failed.T.reshape(-1), fixes.failed)
        if mode == 'conditional':
            np.testing.assert_allclose(errors.covariance.transpose(1, 0, 2, 3).reshape(-1, 2, 2),
                                       rows.cov, rtol=0, atol=1e-9)
        alone = profile.model().simulate(agent_keys(seed, AGENTS), STEPS, start=int(T0))
        np.testing.assert_allclose(alone.reshape(-1, 2), rows.error, rtol=0, atol=TOL_M)


#: effects whose errors depend on the walk: those that turn with it, and the lag
MOVES = tuple(k.name for k in KINDS if k.needs_heading) + ('motion_lag',)


def test_every_effect_of_the_registry_is_drawn():
    """A new module in ``model/effect_kinds`` needs its strategy in ``EFFECTS`` above."""
    assert sorted(EFFECTS) == sorted(k.name for k in KINDS)


# derandomized (the same draws in every run), and no shrinking: a failure prints its draw
@settings(max_examples=int(os.environ.get('ONE_STEP_EXAMPLES', 40)), deadline=None,
          derandomize=True, phases=[Phase.explicit, Phase.generate], print_blob=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(profiles(), st.integers(0, 2 ** 31), st.sampled_from(['stationary', 'conditional',
                                                             'reported']))
def test_every_path_gives_the_same_errors(drawn, seed, mode):
    raw, zone = drawn
    if mode == 'reported' and 'reported_accuracy' not in raw:
        mode = 'conditional'
    check_paths(raw, zone, seed, mode, turning=True)
    still = zone is None and not set(raw.get('effects', {})) & set(MOVES)
    if still:
        check_paths(raw, zone, seed, mode, turning=False)


def ds5_with(effects):
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['effects'] = effects
    return profile_from_dict(raw)


@pytest.mark.parametrize('effects', [
    {'street_frame': {'sigma_along': 0.8, 'sigma_across': 1.6},
     'outliers': {'rate': 0.05, 'mean_steps': 3.0, 'sigma_m': 10.0}},
    {'street_frame': {'sigma_along': 0.8, 'sigma_across': 1.6},
     'periodic': {'period_steps': 4, 'scales': [1.2, 0.8, 1.0, 1.0],
                  'offsets': [[0.5, -0.5], [-0.5, 0.5], [0.2, 0.1], [-0.2, -0.1]]}},
], ids=['street frame and outliers', 'street frame and a cycle'])
def test_a_street_frame_walk_due_north_is_the_models_own_errors(effects):
    """
    The reviewer's case: DS5, seed 3, due north at 1.4 m/s for 300 s.

    ``add_errors`` differed from ``simulate_errors`` by up to 71 m with
    outliers (the jump was stored as AR history) and 2 m with a cycle (its
    phase was lost every step).
    """
    p = ds5_with(effects)
    t = np.arange(0.0, 300.0)
    a = ge.add_errors(p, t, seed=3, east=np.zeros(t.size), north=1.4 * t,
                      datum=[40.75, -73.99])
    s = ge.simulate_errors(p, [''], duration_s=300, seed=3)
    got = np.stack([a.north, a.east], 1) - np.stack([1.4 * t, np.zeros(t.size)], 1)
    # through latitude and longitude and back: the geodesy's round trip, not the model
    assert np.abs(got - s.north_east[0]).max() < 1e-5
    frame = LocalTangentFrame(40.75, -73.99, 0.0)
    lat, lon, _ = frame.to_geodetic(np.zeros(t.size), 1.4 * t, np.zeros(t.size))
    rows, _ = trajectory_fixes({'t': t, 'agent': [''] * t.size, 'truth_lat': lat,
                                'truth_lon': lon}, p.model(about_truth=True), 1.0, 3)
    np.testing.assert_array_equal(rows.error, s.north_east[0])

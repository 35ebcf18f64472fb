"""gps_error simulate: SUMO FCD and CSV trajectories, raw series, node agreement."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from gps_error_ros.model import streams
from gps_error_ros.sim.simulate import simulate_fcd, simulate_npz
from gps_error_ros.cli import main as cli
from gps_error_ros.model.geodesy import difference
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.traces.trace_io import read_trace_csv
from gps_error_ros.traces.trajectories import TrajectoryError

MODEL = load_profile('DS2').model()
LAT0, LON0 = 48.85, 2.35
UTM31 = '+proj=utm +zone=31 +ellps=WGS84 +datum=WGS84 +units=m +no_defs'


def presence(i, t):
    """Return whether ped i is present: from t = 3i to t = 40 + 5i."""
    return 3 * i <= t <= 40 + 5 * i


def sumo_comment(geo, root='configuration'):
    """
    Return the options comment SUMO writes at the top of its outputs.

    ``root``: ``configuration`` (options on the command line) or
    ``sumoConfiguration`` (SUMO 1.28 run with ``-c``).
    """
    option = '        <fcd-output.geo value="true"/>\n' if geo else ''
    return ('<!-- generated on 2026-11-22 10:00:00 by Eclipse SUMO sumo Version 1.28.0\n'
            f'<{root} xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance">\n'
            '    <output>\n        <fcd-output value="fcd.xml"/>\n' + option +
            f'    </output>\n</{root}>\n-->\n\n')


def write_fcd(path, positions, header=''):
    """positions(i, t) -> (x, y); 6 persons, t = 10..70 s, plus one vehicle."""
    with open(path, 'w') as f:
        f.write('<?xml version="1.0" encoding="UTF-8"?>\n' + header + '<fcd-export>\n')
        for t in range(10, 71):
            f.write(f'  <timestep time="{t:.2f}">\n')
            x, y = positions(99, t)
            f.write(f'    <vehicle id="veh0" x="{x!r}" y="{y!r}" angle="90" type="car" '
                    f'speed="10" pos="1" lane="e_0" slope="0"/>\n')
            for i in range(6):
                if presence(i, t - 10):
                    x, y = positions(i, t)
                    f.write(f'    <person id="ped{i}" x="{x!r}" y="{y!r}" angle="0" '
                            f'speed="1.3" pos="2" edge="e" slope="0"/>\n')
            f.write('  </timestep>\n')
        f.write('</fcd-export>\n')


def read_fcd(path):
    out = {}
    for ts in ET.parse(path).getroot():
        t = float(ts.get('time'))
        for c in ts:
            out[c.get('id'), t] = (float(c.get('x')), float(c.get('y')), c.tag, c.attrib)
    return out


def reference(name, t, seed):
    """Return the node's error for ``name`` at time t of a run starting at 10 s."""
    series = MODEL.simulate(streams.agent_key(seed, name), 61, start=10)
    return series[int(t) - 10, 0]


@pytest.mark.parametrize('kind', ['geo', 'utm', 'planar'])
def test_fcd_errors_are_the_agents_streams(tmp_path, kind):
    from pyproj import Transformer
    utm = Transformer.from_crs('EPSG:4326', UTM31, always_xy=True)
    offset_xy = (-448000.0, -5411000.0)

    def lonlat(i, t):
        return LON0 + 1e-5 * (i + 1) * t, LAT0 + 2e-5 * i

    if kind == 'geo':
        positions, net = lonlat, None
    elif kind == 'utm':
        def positions(i, t):
            x, y = utm.transform(*lonlat(i, t))
            return x + offset_xy[0], y + offset_xy[1]
        net = tmp_path / 'net.net.xml'
        net.write_text(f'<net version="1.16"><location netOffset="{offset_xy[0]},'
                       f'{offset_xy[1]}" convBoundary="0,0,1,1" origBoundary="0,0,1,1" '
                       f'projParameter="{UTM31}"/></net>')
    else:
        def positions(i, t):
            return 10.0 * i + t, 5.0 * i
        net = tmp_path / 'flat.net.xml'
        net.write_text('<net><location netOffset="0.00,0.00" convBoundary="0,0,9,9" '
                       'origBoundary="0,0,9,9" projParameter="!"/></net>')
    src, dst = tmp_path / 'fcd.xml', tmp_path / 'noisy.xml'
    write_fcd(src, positions, sumo_comment(geo=kind == 'geo'))
    res = simulate_fcd(src, dst, MODEL, 1.0, 5, net)
    assert res['timesteps'] == 61 and res['agents'] == 7
    a, b = read_fcd(src), read_fcd(dst)
    assert a.keys() == b.keys()
    for (name, t), (x, y, tag, attrs) in a.items():
        nx, ny, ntag, nattrs = b[name, t]
        assert ntag == tag and nattrs['speed'] == attrs['speed']
        ref = reference(name, t, 5)
        if kind == 'planar':
            got = (ny - y, nx - x)
            tol = 2e-3
        else:
            if kind == 'utm':
                inv = Transformer.from_crs(UTM31, 'EPSG:4326', always_xy=True)
                x, y = inv.transform(x - offset_xy[0], y - offset_xy[1])
                nx, ny = inv.transform(nx - offset_xy[0], ny - offset_xy[1])
            got = difference(ny, nx, y, x)
            tol = 5e-3
        np.testing.assert_allclose(got, ref, atol=tol, err_msg=f'{name} {t}')
    # the phone's speed and course in every coordinate kind: due east, at the truth's speed
    from gps_error_ros.model.velocity import velocity_from_dict
    vel = velocity_from_dict({'sigma': 1e-6, 'phi': 0.5, 'lag_s': 0.0, 'standstill': 0.0})
    simulate_fcd(src, dst, MODEL, 1.0, 5, net, velocity=vel)
    moving = [(k, v[3]) for k, v in read_fcd(dst).items() if 'reported_speed' in v[3]]
    assert len(moving) > 150
    for (name, t), attrs in moving:
        i = 99 if name == 'veh0' else int(name[3:])
        want = 1.0 if kind == 'planar' else 1e-5 * (i + 1) * 111320 * np.cos(np.radians(LAT0))
        assert float(attrs['reported_speed']) == pytest.approx(want, rel=5e-3), (name, t)
        assert float(attrs['reported_bearing']) == pytest.approx(90.0, abs=0.2), (name, t)


def test_fcd_bad_input(tmp_path):
    bad = tmp_path / 'bad.xml'
    bad.write_text('<routes><vehicle id="x"/></routes>')
    with pytest.raises(TrajectoryError, match='expected <fcd-export>'):
        simulate_fcd(bad, tmp_path / 'o.xml', MODEL, 1.0, 1)
    write_fcd(bad, lambda i, t: (1000.0 + t, 2000.0), sumo_comment(geo=False))
    with pytest.raises(TrajectoryError, match='--net'):
        simulate_fcd(bad, tmp_path / 'o.xml', MODEL, 1.0, 1)
    bad.write_text('<fcd-export><timestep time="2"></timestep>'
                   '<timestep time="1"></timestep></fcd-export>')
    with pytest.raises(TrajectoryError, match='increasing'):
        simulate_fcd(bad, tmp_path / 'o.xml', MODEL, 1.0, 1, coordinates='lonlat')
    assert cli(['simulate', '--seed', '1', '--trajectories', str(bad),
                '--out', str(tmp_path / 'o.xml'), '--coordinates', 'lonlat']) == 2
    assert list(tmp_path.iterdir()) == [bad]         # no partial output, ever


def test_fcd_coordinates_are_read_not_guessed(tmp_path):
    """A small planar net (x, y inside lon/lat ranges) is never taken for degrees."""
    def small(i, t):
        return 50.3 + t, 20.1 + i
    src, out = tmp_path / 'fcd.xml', tmp_path / 'o.xml'
    write_fcd(src, small, sumo_comment(geo=False))
    with pytest.raises(TrajectoryError, match='x/y metres.*--net'):
        simulate_fcd(src, out, MODEL, 1.0, 1)
    assert not out.exists()
    write_fcd(src, small)                               # hand-written: no comment
    with pytest.raises(TrajectoryError, match='--coordinates'):
        simulate_fcd(src, out, MODEL, 1.0, 1)
    flat = tmp_path / 'flat.net.xml'
    flat.write_text('<net><location netOffset="0.00,0.00" convBoundary="0,0,9,9" '
                    'origBoundary="0,0,9,9" projParameter="!"/></net>')
    simulate_fcd(src, out, MODEL, 1.0, 1, flat, coordinates='xy')
    moved = read_fcd(out)
    x, y, _, _ = moved['ped0', 20.0]
    assert abs(x - 60.3) < 50 and abs(y - 20.1) < 50      # metres, not degrees
    write_fcd(src, lambda i, t: (LON0, LAT0), sumo_comment(geo=True))
    assert simulate_fcd(src, out, MODEL, 1.0, 1)['positions'] > 0
    # SUMO run with -c names its options <sumoConfiguration>
    write_fcd(src, lambda i, t: (LON0, LAT0), sumo_comment(True, 'sumoConfiguration'))
    assert simulate_fcd(src, out, MODEL, 1.0, 1)['positions'] > 0
    write_fcd(src, small, sumo_comment(False, 'sumoConfiguration'))
    with pytest.raises(TrajectoryError, match='x/y metres.*--net'):
        simulate_fcd(src, out, MODEL, 1.0, 1)


def test_csv_round_trip_through_calibrate(tmp_path):
    src = tmp_path / 'truth.csv'
    with open(src, 'w') as f:
        f.write('t,agent,truth_lat,truth_lon\n')
        for t in range(3000):
            f.write(f'{t},walker,{LAT0 + 1e-6 * t!r},{LON0!r}\n')
    out = tmp_path / 'noisy.csv'
    assert cli(['simulate', '--profile', 'DS1', '--seed', '2', '--trajectories',
                str(src), '--out', str(out)]) == 0
    assert cli(['calibrate', str(out), '-o', str(tmp_path / 'p.yaml'), '--order', '3']) == 0
    from gps_error_ros.model.profiles import load_profile_file
    fitted, ds1 = load_profile_file(tmp_path / 'p.yaml'), load_profile('DS1')
    for ax in ('north', 'east'):
        assert abs(fitted.axes[ax].sigma_w - ds1.axes[ax].sigma_w) < \
            5 * ds1.axes[ax].sigma_w / np.sqrt(2 * 3000)


def test_npz_matches_library_and_streams(tmp_path):
    res = simulate_npz(tmp_path / 'e.npz', MODEL, 1.0, 9, 1500, 120.0, start_s=30)
    d = np.load(tmp_path / 'e.npz')
    assert res == {'agents': 1500, 'steps': 120}
    assert d['errors'].shape == (1500, 120, 2) and d['t'][0] == 30.0
    ref = MODEL.simulate(streams.agent_key(9, 'agent1234'), 120, start=30)[:, 0]
    np.testing.assert_allclose(d['errors'][1234], ref, atol=1e-9)


def test_fcd_summary_counts_every_agent_seen(tmp_path):
    """An agent gone for longer than the crowd remembers is still counted."""
    src = tmp_path / 'fcd.xml'
    src.write_text(sumo_comment(geo=True) + '<fcd-export>\n'
                   '<timestep time="0.00"><person id="a" x="-73.99" y="40.75"/>'
                   '<person id="b" x="-73.99" y="40.75"/></timestep>\n'
                   '<timestep time="960.00"><person id="c" x="-73.99" y="40.75"/>'
                   '</timestep>\n</fcd-export>\n')
    model = load_profile('DS2').model()
    res = simulate_fcd(src, tmp_path / 'out.xml', model, 1.0, 1)
    assert res == {'timesteps': 2, 'positions': 3, 'agents': 3}


def test_outages_leave_gaps_where_the_stream_has_them(tmp_path):
    """With availability: FCD positions left out, CSV rows marked no_fix (read as gaps)."""
    from gps_error_ros.model.availability import availability_from_dict, WithAvailability
    from gps_error_ros.sim.simulate import simulate_csv
    av = availability_from_dict({'outage_rate': 0.1, 'durations': [[2, 0.5], [5, 0.5]]})
    model = WithAvailability(MODEL, av)
    src, out = tmp_path / 'fcd.xml', tmp_path / 'o.xml'
    write_fcd(src, lambda i, t: (LON0 + 1e-5 * t, LAT0 + 1e-5 * i), sumo_comment(geo=True))
    res = simulate_fcd(src, out, model, 1.0, 4)
    plain = simulate_fcd(src, tmp_path / 'p.xml', MODEL, 1.0, 4)
    assert res['positions'] + res['positions_without_fix'] == plain['positions']
    assert res['positions_without_fix'] > 0
    moved, every = read_fcd(out), read_fcd(tmp_path / 'p.xml')
    for name in ('ped0', 'ped3', 'veh0'):
        steps = sorted(t for (n, t) in every if n == name)
        first = int(read_fcd_first_time(src))
        mask = model.simulate_fix(
            np.array([streams.agent_key(4, name)], dtype=np.uint64), 80, start=first)[0]
        kept = sorted(t for (n, t) in moved if n == name)
        assert kept == [t for t in steps if mask[int(t) - first]], name
        for t in kept:           # the errors are those without availability
            assert moved[name, t][:2] == pytest.approx(every[name, t][:2], abs=1e-9)
    csv_src = tmp_path / 'truth.csv'
    csv_src.write_text('t,agent,truth_lat,truth_lon\n' + ''.join(
        f'{t},w,{LAT0!r},{LON0!r}\n' for t in range(100)))
    res = simulate_csv(csv_src, tmp_path / 'o.csv', model, 1.0, 4)
    mask = model.simulate_fix(
        np.array([streams.agent_key(4, 'w')], dtype=np.uint64), 100, start=0)[0]
    lines = (tmp_path / 'o.csv').read_text().splitlines()
    assert lines[0].startswith('t,agent,status,lat,lon,')
    status = [r.split(',')[2] for r in lines[1:]]
    assert status == ['fix' if m else 'no_fix' for m in mask]
    assert all(r.split(',')[3:5] == ['', ''] for r in lines[1:] if ',no_fix,' in r)
    assert res['positions_without_fix'] == int((~mask).sum()) > 0
    back = read_trace_csv(tmp_path / 'o.csv')        # no-fix rows read as gaps
    np.testing.assert_array_equal(back.t, np.flatnonzero(mask).astype(float))


def read_fcd_first_time(path):
    """Return the time of an FCD file's first timestep."""
    return float(next(ET.parse(path).getroot().iter('timestep')).get('time'))


def test_npz_carries_the_fix_mask_with_availability(tmp_path):
    from gps_error_ros.model.availability import availability_from_dict, WithAvailability
    av = availability_from_dict({'outage_rate': 0.1, 'durations': [[3, 1.0]]})
    model = WithAvailability(MODEL, av)
    simulate_npz(tmp_path / 'e.npz', model, 1.0, 6, 5, 200, chunk=2)
    simulate_npz(tmp_path / 'p.npz', MODEL, 1.0, 6, 5, 200, chunk=2)
    with np.load(tmp_path / 'e.npz') as a, np.load(tmp_path / 'p.npz') as b:
        np.testing.assert_array_equal(a['errors'], b['errors'])     # errors unchanged
        assert 'fix' not in b
        keys = np.array([streams.agent_key(6, f'agent{i}') for i in range(5)], dtype=np.uint64)
        np.testing.assert_array_equal(a['fix'], model.simulate_fix(keys, 200))
        assert 0 < (~a['fix']).sum() < a['fix'].size


def test_fcd_positions_state_their_accuracy(tmp_path):
    """
    Every position written carries the stated accuracy of the CSV mode.

    Stationary: the profile's one ellipse for all; conditional with variance
    regimes: the covariance of each step given the state before, so it varies.
    """
    import yaml
    from gps_error_ros.model.accuracy import ellipse, radius68
    from gps_error_ros.model.profiles import builtin_dir, profile_from_dict
    src = tmp_path / 'fcd.xml'
    write_fcd(src, lambda i, t: (LON0 + 1e-5 * t, LAT0 + 1e-4 * i), sumo_comment(True))
    dst = tmp_path / 'noisy.xml'
    simulate_fcd(src, dst, MODEL, 1.0, 5)
    cov = MODEL.stationary_cov
    major, minor, orient = ellipse(cov)
    want = {'accuracy': float(radius68(cov)), 'accuracy_major': float(major),
            'accuracy_minor': float(minor), 'accuracy_orientation': float(orient)}
    elems = [e for ts in ET.parse(dst).getroot() for e in ts]
    assert len(elems) > 200
    for e in elems:
        for k, v in want.items():
            assert float(e.get(k)) == pytest.approx(v, abs=6e-4), (k, e.attrib)
    raw = yaml.safe_load((builtin_dir() / 'DS2.yaml').read_text())
    raw['effects'] = {'variance_regimes': {'scales': [1.0, 3.0],
                                           'transition': [[0.8, 0.2], [0.3, 0.7]]}}
    regimes = profile_from_dict(raw).model()
    simulate_fcd(src, dst, regimes, 1.0, 5, covariance_mode='conditional')
    acc = {float(e.get('accuracy')) for ts in ET.parse(dst).getroot() for e in ts}
    assert len(acc) >= 3, acc


def test_reported_accuracy_is_each_agents_own_in_csv_and_fcd(tmp_path):
    """
    covariance_mode reported: the stated radius of every position is its agent's own.

    With variance regimes and ``follow`` 1 the radius follows each agent's
    predicted scale, with its own fluctuation: the CSV mode equals the
    library computed for one agent alone, and the FCD mode the CSV mode.
    """
    import yaml
    from gps_error_ros.model.profiles import builtin_dir, profile_from_dict
    from gps_error_ros.model.reported import reference_cov
    from gps_error_ros.sim.simulate import simulate_csv
    raw = yaml.safe_load((builtin_dir() / 'DS2.yaml').read_text())
    raw['effects'] = {'variance_regimes': {'scales': [1.0, 3.0],
                                           'transition': [[0.8, 0.2], [0.3, 0.7]]}}
    raw['reported_accuracy'] = {'source': 'accuracy', 'median_m': 3.0, 'follow': 1.0,
                                'phi': 0.9, 'sigma_log': 0.3, 'resolution_m': 0.5,
                                'scale_m': 0.0}
    profile = profile_from_dict(raw)
    model, rep = profile.model(), profile.reported_accuracy
    src = tmp_path / 'fcd.xml'
    write_fcd(src, lambda i, t: (LON0 + 1e-5 * t, LAT0 + 1e-4 * i), sumo_comment(True))
    fcd = tmp_path / 'noisy.xml'
    simulate_fcd(src, fcd, model, 1.0, 5, covariance_mode='reported', reported=rep)
    got_fcd = {k: float(v[3]['accuracy']) for k, v in read_fcd(fcd).items()}
    rows = ['t,agent,truth_lat,truth_lon'] + [
        f'{t},{name},{LAT0 + 1e-4 * (99 if name == "veh0" else int(name[3:]))},'
        f'{LON0 + 1e-5 * t}' for name, t in sorted(got_fcd, key=lambda p: (p[1], p[0]))]
    truth = tmp_path / 'truth.csv'
    truth.write_text('\n'.join(rows) + '\n')
    out = tmp_path / 'noisy.csv'
    simulate_csv(truth, out, model, 1.0, 5, covariance_mode='reported', reported=rep)
    got_csv = {}
    for name in {n for n, _ in got_fcd}:
        trace = read_trace_csv(out, agent=name)
        got_csv.update({(name, float(t)): a for t, a in zip(trace.t, trace.extra['accuracy'])})
    assert set(got_csv) == set(got_fcd)
    for k, a in got_csv.items():
        assert got_fcd[k] == pytest.approx(a, abs=6e-4), k
    # one agent alone, from the library: its predicted scale and its own fluctuation
    keys = np.array([streams.agent_key(5, 'ped2')], dtype=np.uint64)
    state = model.initial_state(keys, 10)
    covs = [model.predictive_cov(state, first=True)[0]]
    for k in range(11, 71):
        covs.append(model.predictive_cov(state)[0])
        model.advance(state, keys, k)
    radius = rep.radius(rep.errors(keys, 61, 10)[:, 0], np.array(covs), reference_cov(model))
    mine = {t: a for (n, t), a in got_csv.items() if n == 'ped2'}
    assert len(mine) > 30
    for t, a in mine.items():
        assert a == radius[int(t) - 10], t
    assert len(set(mine.values())) >= 4                 # it varies, in 0.5 m steps
    assert all(v % 0.5 == 0 for v in mine.values())


@pytest.mark.parametrize('course_lag', [None, 0.9])
def test_fcd_positions_report_the_phones_speed_and_course(tmp_path, course_lag):
    """
    With a velocity section FCD positions carry the CSV mode's speed and bearing.

    As ``reported_speed`` and ``reported_bearing`` (SUMO's ``speed`` and
    ``angle`` stay the truth's); none where the truth does not reach back a
    second yet (with a course lag, back to its chord's start).
    """
    from gps_error_ros.model.velocity import velocity_from_dict
    from gps_error_ros.sim.simulate import simulate_csv
    section = {'sigma': 0.2, 'phi': 0.7, 'lag_s': 0.3, 'standstill': 0.0}
    if course_lag is not None:
        section.update(course_lag_s=course_lag, speed_bias=[[1.0, -0.2], [3.0, 0.1]],
                       scale_sd_log=0.5, burst_share=0.2, burst_ratio=4.0)
    vel = velocity_from_dict(section)
    src = tmp_path / 'fcd.xml'
    pos = lambda i, t: (LON0 + 2e-5 * t * (1 + i % 3), LAT0 + 1e-4 * i + 1e-6 * t * t)  # noqa
    write_fcd(src, pos, sumo_comment(True))
    fcd = tmp_path / 'noisy.xml'
    simulate_fcd(src, fcd, MODEL, 1.0, 7, velocity=vel)
    elems = read_fcd(fcd)
    got = {k: v[3] for k, v in elems.items()}
    assert all(a['speed'] in ('10', '1.3') for a in got.values())     # SUMO's, untouched
    rows = ['t,agent,truth_lat,truth_lon'] + [
        f'{t},{name},{pos(99 if name == "veh0" else int(name[3:]), t)[1]!r},'
        f'{pos(99 if name == "veh0" else int(name[3:]), t)[0]!r}'
        for name, t in sorted(got, key=lambda p: (p[1], p[0]))]
    truth = tmp_path / 'truth.csv'
    truth.write_text('\n'.join(rows) + '\n')
    out = tmp_path / 'noisy.csv'
    simulate_csv(truth, out, MODEL, 1.0, 7, velocity=vel)
    compared = 0
    for name in {n for n, _ in got}:
        trace = read_trace_csv(out, agent=name)
        for t, s, b in zip(trace.t, trace.extra['speed'], trace.extra['bearing']):
            attrs = got[name, float(t)]
            if not np.isfinite(s):
                assert 'reported_speed' not in attrs, (name, t)
                continue
            assert float(attrs['reported_speed']) == pytest.approx(s, abs=6e-4), (name, t)
            assert float(attrs['reported_bearing']) == pytest.approx(b, abs=6e-3), (name, t)
            compared += 1
    assert compared > 200


SUMO_COMMENT = '''<?xml version="1.0" encoding="UTF-8"?>

<!-- generated on 2026-11-25 by Eclipse SUMO sumo 1.28.0
<sumoConfiguration>
    <input>
        <net-file value="grid.net.xml"/>
    </input>
    <output>
        <fcd-output value="fcd.xml"/>
        <fcd-output.geo value="true"/>
    </output>
</sumoConfiguration>
-->

'''


def _net(path, proj):
    path.write_text(f'<net><location netOffset="0.00,0.00" convBoundary="0,0,200,200" '
                    f'origBoundary="0,0,200,200" projParameter="{proj}"/></net>')


@pytest.mark.parametrize('proj, refused', [('!', True),
                                           ('+proj=utm +zone=18 +ellps=WGS84', False)])
def test_geo_output_from_a_net_without_projection_is_refused(tmp_path, capsys, proj, refused):
    """SUMO writes x/y metres under --fcd-output.geo when its net has no projection."""
    from gps_error_ros.cli import main as gps_error
    _net(tmp_path / 'grid.net.xml', proj)
    lon, lat = ('2.88', '3.2') if refused else ('-73.99', '40.75')
    (tmp_path / 'fcd.xml').write_text(
        SUMO_COMMENT + '<fcd-export>\n' + ''.join(
            f'<timestep time="{k}.00"><person id="p0" x="{lon}" y="{lat}" angle="0" '
            f'speed="0" pos="0" edge="A0A1" slope="0"/></timestep>\n' for k in range(3))
        + '</fcd-export>\n')
    out = tmp_path / 'o.xml'
    rc = gps_error(['simulate', '--profile', 'DS5', '--seed', '1', '--trajectories',
                    str(tmp_path / 'fcd.xml'), '--out', str(out)])
    err = capsys.readouterr().err
    if refused:
        assert rc == 2 and not out.exists()
        assert 'has no projection' in err and 'wrote x/y metres, not lon/lat' in err, err
        assert '--coordinates xy --net' in err
    else:
        assert rc == 0 and out.exists(), err


def test_an_fcd_without_positions_is_an_error(tmp_path, capsys):
    from gps_error_ros.cli import main as gps_error
    for body in ('', '<timestep time="0.00"/>\n<timestep time="1.00"/>\n'):
        src = tmp_path / 'empty.xml'
        src.write_text(f'<?xml version="1.0"?>\n<fcd-export>\n{body}</fcd-export>\n')
        out = tmp_path / 'o.xml'
        assert gps_error(['simulate', '--profile', 'DS5', '--seed', '1', '--coordinates',
                          'lonlat', '--trajectories', str(src), '--out', str(out)]) == 2
        assert 'no person or vehicle in any' in capsys.readouterr().err
        assert not out.exists()


def test_one_agent_to_nmea_gives_the_csv_fixes_as_a_receiver_streams_them(tmp_path):
    """The NMEA output holds the CSV's fixes, outages as quality 0, the accuracy in GST."""
    import datetime as dt

    import pynmea2
    import yaml

    from gps_error_ros.model.profiles import builtin_dir
    from gps_error_ros.traces.nmea import read_nmea
    from gps_error_ros.model.accuracy import radius68
    from gps_error_ros.traces.nmea_write import GPSD_UERE_M
    raw = yaml.safe_load((builtin_dir() / 'DS2.yaml').read_text())
    raw['availability'] = {'outage_rate': 0.1, 'durations': [[2, 0.5], [5, 0.5]]}
    profile = tmp_path / 'outages.yaml'
    profile.write_text(yaml.safe_dump(raw))
    src = tmp_path / 'truth.csv'
    src.write_text('t,agent,truth_lat,truth_lon\n' + ''.join(
        f'{t},w,{LAT0 + 1e-5 * t!r},{LON0!r}\n' for t in range(200)))
    common = ['simulate', '--profile', str(profile), '--seed', '6', '--trajectories', str(src),
              '--covariance-mode', 'conditional']
    assert cli(common + ['--out', str(tmp_path / 'o.csv')]) == 0
    assert cli(common + ['--out', str(tmp_path / 'o.nmea'),
                         '--utc-start', '2026-11-28T23:58:00']) == 0
    csv_fixes = read_trace_csv(tmp_path / 'o.csv')
    nmea = read_nmea(tmp_path / 'o.nmea')
    start = dt.datetime(2026, 11, 28, 23, 58, tzinfo=dt.timezone.utc).timestamp()
    np.testing.assert_allclose(nmea.t - start, csv_fixes.t, atol=1e-6)    # past midnight too
    np.testing.assert_allclose(nmea.lat, csv_fixes.lat, atol=1e-9)
    np.testing.assert_allclose(nmea.lon, csv_fixes.lon, atol=1e-9)
    assert nmea.skipped['no fix'] == 200 - len(csv_fixes.t) > 0 and \
        nmea.skipped['bad checksum'] == 0
    # the stated accuracy: GST's axes' SDs from the CSV's ellipse, HDOP its scale of them
    ellipse = np.stack([csv_fixes.extra['accuracy_major'], csv_fixes.extra['accuracy_minor']])
    gst = [pynmea2.parse(line) for line in (tmp_path / 'o.nmea').read_text().split()
           if line.startswith('$GPGST')]
    assert len(gst) == len(csv_fixes.t)
    sds = np.array([[g.std_dev_latitude, g.std_dev_longitude] for g in gst])
    np.testing.assert_allclose(np.hypot(*sds.T), np.hypot(*ellipse), atol=2e-3)
    assert len({round(g.std_dev_major, 3) for g in gst}) > 1       # conditional: per fix
    cov = np.array([[[g.std_dev_latitude ** 2, 0.0], [0.0, g.std_dev_longitude ** 2]]
                    for g in gst])
    major = np.array([g.std_dev_major for g in gst])
    # HDOP x gpsd's 19 m: the 95 % radius (of the ellipse; the axes' SDs alone drop its tilt)
    r95 = radius68(np.array([[[a * a, 0.0], [0.0, b * b]] for a, b in ellipse.T]), 0.95)
    np.testing.assert_allclose(nmea.extra['hdop'] * GPSD_UERE_M, r95, atol=0.005 * GPSD_UERE_M)
    assert np.all(major >= np.sqrt(cov[:, 0, 0]) - 1e-3)


def test_nmea_output_takes_one_agent(tmp_path, capsys):
    src = tmp_path / 'two.csv'
    src.write_text('t,agent,truth_lat,truth_lon\n0,a,48.85,2.35\n0,b,48.85,2.35\n')
    assert cli(['simulate', '--seed', '1', '--trajectories', str(src),
                '--out', str(tmp_path / 'o.nmea')]) == 2
    err = capsys.readouterr().err
    assert '2 agents (a, b): an NMEA file is one receiver\'s stream' in err, err
    assert not (tmp_path / 'o.nmea').exists()


def test_faults_from_the_command_line_reach_csv_and_nmea(tmp_path, capsys):
    from gps_error_ros.traces.nmea import read_nmea
    src = tmp_path / 'truth.csv'
    src.write_text('t,agent,truth_lat,truth_lon\n' + ''.join(
        f'{t},w,{LAT0 + 1e-5 * t!r},{LON0!r}\n' for t in range(60)))
    schedule = tmp_path / 'faults.yaml'
    schedule.write_text('faults:\n  - {kind: outage, at: 10, duration: 5, agent: w}\n'
                        '  - {kind: gross_failure, at: 30, size_m: 4000}\n')
    common = ['simulate', '--seed', '3', '--trajectories', str(src), '--faults', str(schedule)]
    assert cli(common + ['--out', str(tmp_path / 'o.csv')]) == 0
    assert '55 positions, 1 agents, 5 positions_without_fix' in capsys.readouterr().out
    assert cli(common + ['--out', str(tmp_path / 'o.nmea')]) == 0
    nmea = read_nmea(tmp_path / 'o.nmea')
    fixes = read_trace_csv(tmp_path / 'o.csv')
    assert nmea.skipped['no fix'] == 5 and not np.isin(np.arange(10, 15), fixes.t).any()
    far = np.hypot(*difference(fixes.lat, fixes.lon, fixes.truth_lat, fixes.truth_lon))
    assert fixes.t[far > 3000].tolist() == [30.0]
    np.testing.assert_allclose(nmea.lat, fixes.lat, atol=1e-9)
    # the raw mode takes no faults, and says so before any work
    assert cli(['simulate', '--seed', '3', '--agents', '2', '--duration', '5',
                '--faults', str(schedule), '--out', str(tmp_path / 'o.npz')]) == 2
    assert 'the raw mode (.npz) has none' in capsys.readouterr().err
    bad = tmp_path / 'bad.yaml'
    bad.write_text('- {kind: frozen, at: 3}\n')
    assert cli(common[:-1] + [str(bad), '--out', str(tmp_path / 'b.csv')]) == 2
    assert f'fault schedule {bad}: fault 1: frozen needs duration' in capsys.readouterr().err
    assert not (tmp_path / 'b.csv').exists()


def test_faults_in_fcd_are_those_of_the_csv_mode(tmp_path):
    from gps_error_ros.sim.faults import faults_from_yaml
    from gps_error_ros.sim.simulate import simulate_csv

    def walk(i, t):
        return LON0 + 1e-5 * (t + i), LAT0 + 2e-5 * i

    src = tmp_path / 'fcd.xml'
    write_fcd(src, walk, sumo_comment(geo=True))
    truth = tmp_path / 'truth.csv'
    truth.write_text('t,agent,truth_lat,truth_lon\n' + ''.join(
        f'{t},{a},{walk(int(a[3:]) if a != "veh0" else 99, t)[1]!r},'
        f'{walk(int(a[3:]) if a != "veh0" else 99, t)[0]!r}\n'
        for t in range(10, 71) for a in ['veh0'] + [f'ped{i}' for i in range(6)]
        if a == 'veh0' or presence(int(a[3:]), t - 10)))
    faults = faults_from_yaml('''
- {kind: outage, at: 20, duration: 3, agent: ped1}
- {kind: frozen, at: 30, duration: 6, agent: ped2}
- {kind: offset, at: 40, duration: 4, size_m: 50, bearing_deg: 30}
- {kind: degraded, at: 50, duration: 4, scale: 5, agent: veh0}
- {kind: gross_failure, at: 60, size_m: 3000, agent: ped5}
''')
    simulate_fcd(src, tmp_path / 'out.xml', MODEL, 1.0, 9, faults=faults)
    simulate_csv(truth, tmp_path / 'out.csv', MODEL, 1.0, 9, faults=faults)
    import csv
    fcd = read_fcd(tmp_path / 'out.xml')
    with open(tmp_path / 'out.csv', newline='') as f:
        rows = [r for r in csv.DictReader(f) if r['lat']]
    assert len(rows) == len(fcd)            # the same fixes: none where an outage is
    for r in rows:
        x, y = fcd[r['agent'], float(r['t'])][:2]
        north, east = difference(y, x, float(r['lat']), float(r['lon']))
        assert np.hypot(north, east) < 1e-3, r          # FCD writes 8 digits: ~1 mm
        acc = fcd[r['agent'], float(r['t'])][3]['accuracy']
        assert float(acc) == pytest.approx(float(r['accuracy']), abs=1e-3), r
    assert ('ped1', 20.0) not in fcd and ('ped1', 22.0) not in fcd and ('ped1', 23.0) in fcd
    assert len({fcd['ped2', float(t)][:2] for t in range(30, 36)}) == 1
    x, y = fcd['ped5', 60.0][:2]
    assert np.hypot(*difference(y, x, *walk(5, 60)[::-1])) > 2900

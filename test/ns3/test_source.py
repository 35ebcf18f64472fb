"""
ns-3's nodes get the errors that ``gps_error simulate`` gives the same agents, to 1e-6 m.

:class:`~gps_error_ros.ns3.source.GpsSource` runs in real ns-3 (the extra
``ns3``, installed by ``make test``'s set-up) in a process of its own
(``source_run.py``), on nodes that follow waypoints and an ns-2 mobility
trace. The true positions it read are written as SUMO FCD (lon/lat about
the source's datum) and given to ``gps_error simulate`` with the same
profile and seed. Each node's error, position and fix must be
``simulate``'s: for a profile with outages, a street frame (its error
follows the direction of travel), outliers, a reported velocity and a
stated accuracy, for a shipped preset, and with no profile at all.
"""

import contextlib
import io
import os
from pathlib import Path
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import yaml

from gps_error_ros.cli import main as gps_error
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.model.profiles import builtin_dir
from gps_error_ros.ns3.source import MANHATTAN

HERE = Path(__file__).resolve().parent
TOL_M = 1e-6
SECONDS = 60


def everything(path):
    """Write DS5 with outages, a street frame, outliers, velocity and stated accuracy."""
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    preset = yaml.safe_load((builtin_dir() / 'phone-suburban-drive.yaml').read_text())
    raw.update(name='ds5-everything',
               effects={'street_frame': {'sigma_along': 0.8, 'sigma_across': 1.6},
                        'outliers': {'rate': 0.05, 'mean_steps': 3.0, 'sigma_m': 10.0}},
               availability={'outage_rate': 0.08,
                             'durations': [[2, 0.5], [5, 0.3], [12, 0.2]]},
               velocity=preset['velocity'], reported_accuracy=preset['reported_accuracy'])
    path.write_text(yaml.safe_dump(raw))
    return str(path)


def in_ns3(profile, seed, folder, fcd=()):
    """Run the source in ns-3 (a process of its own); return what it saved."""
    out = folder / 'ns3.npz'
    run = subprocess.run([sys.executable, str(HERE / 'source_run.py'), *fcd, profile,
                          str(seed), str(SECONDS), str(out)], capture_output=True, text=True,
                         timeout=600, env={**os.environ, 'PYTHONUNBUFFERED': '1'})
    assert run.returncode == 0, run.stderr[-3000:]
    return dict(np.load(out))


def write_fcd(path, t, names, lat, lon, present=None):
    """Write SUMO FCD (lon/lat) of agents ``names`` at times ``t`` (``present``: who is there)."""
    with open(path, 'w') as f:
        f.write('<?xml version="1.0" encoding="UTF-8"?>\n<fcd-export>\n')
        for k, tk in enumerate(t):
            f.write(f'  <timestep time="{tk:.2f}">\n')
            for i, name in enumerate(names):
                if present is None or present[k, i]:
                    f.write(f'    <person id="{name}" x="{float(lon[k, i])!r}" '
                            f'y="{float(lat[k, i])!r}" angle="0" speed="1" pos="0" '
                            f'edge="e"/>\n')
            f.write('  </timestep>\n')
        f.write('</fcd-export>\n')


def simulated(got, profile, seed, folder, src=None, extra=(), stated=None):
    """
    Return ``simulate``'s errors and positions for the truth ns-3 read (or of ``src``).

    ``extra``: more of ``simulate``'s options; ``stated``: a dict to fill with
    its stated-accuracy columns, (epochs, nodes, 4).
    """
    frame = LocalTangentFrame(*MANHATTAN)
    dst = folder / 'noisy.xml'
    if src is None:
        lat, lon, _ = frame.to_geodetic(got['truth'][..., 0], got['truth'][..., 1])
        src = folder / 'truth.xml'
        write_fcd(src, got['t'], got['names'], lat, lon)
    with contextlib.redirect_stdout(io.StringIO()):
        assert gps_error(['simulate', '--trajectories', str(src), '--out', str(dst),
                          '--coordinates', 'lonlat', '--digits', '12', '--errors',
                          '--profile', profile, '--seed', str(seed), *extra]) == 0
    columns = ('accuracy', 'accuracy_major', 'accuracy_minor', 'accuracy_orientation')
    shape = got['fix'].shape
    err, pos = np.full(shape + (2,), np.nan), np.full(shape + (2,), np.nan)
    acc = np.full(shape + (4,), np.nan)
    index = {str(n): i for i, n in enumerate(got['names'])}
    for k, step in enumerate(ET.parse(dst).getroot()):
        for p in step:
            i = index[p.get('id')]
            err[k, i] = float(p.get('error_north')), float(p.get('error_east'))
            e, n, _ = frame.to_enu(float(p.get('y')), float(p.get('x')))
            pos[k, i] = e, n
            acc[k, i] = [float(p.get(c)) for c in columns]
    if stated is not None:
        stated['accuracy'] = acc
    return err, pos


@pytest.mark.parametrize('profile, mode', [('everything', 'stationary'),
                                           ('phone-suburban-drive', 'reported')])
def test_the_nodes_errors_are_simulates(profile, mode, tmp_path):
    """
    Errors, positions, fixes and stated accuracy are ``simulate``'s for the same truth and seed.

    ``reported``: the phone's own radius, whose ellipse holds the profile's
    mean as ``simulate``'s does. ``simulate`` writes the accuracy to the
    millimetre (and the orientation to a thousandth of a degree).
    """
    spec = everything(tmp_path / 'everything.yaml') if profile == 'everything' else profile
    got = in_ns3(spec, 11, tmp_path, ('--covariance-mode', mode))
    stated = {}
    err, pos = simulated(got, spec, 11, tmp_path, extra=('--covariance-mode', mode),
                         stated=stated)
    fix = got['fix']
    assert np.abs(got['accuracy'][fix] - stated['accuracy'][fix]).max() < 5.1e-4
    assert np.array_equal(fix, ~np.isnan(err[..., 0])), 'a fix in ns-3 and not in simulate'
    assert fix.any()
    if profile == 'everything':
        assert not fix.all(), 'the profile has outages: some epoch should have no fix'
    ours = np.stack([got['error'][..., 0], got['error'][..., 1]], -1)
    assert np.abs(ours[fix] - err[fix]).max() < TOL_M
    assert np.abs(got['position'][fix] - pos[fix]).max() < TOL_M
    moved = np.hypot(*(got['position'] - got['truth'])[fix].T)
    assert np.median(moved) > 0.1, 'the positions should carry the errors'


def test_no_profile_gives_the_truth(tmp_path):
    """Without a profile every node knows its true position, and always has a fix."""
    got = in_ns3('none', 1, tmp_path)
    assert got['fix'].all()
    assert np.array_equal(got['position'], got['truth'])
    assert got['t'].tolist() == list(range(SECONDS + 1))
    assert np.allclose(got['truth'][20, 4], [5.0 + 18 * 1.4, -3.0])     # the ns-2 trace


def test_sumo_fcd_as_ns3_nodes_gets_simulates_errors(tmp_path):
    """
    A node per agent of an FCD file (one comes late, one leaves early): simulate's errors.

    With faults laid over the fixes: an outage (no fix), a frozen receiver
    and an offset, as ``simulate --faults`` lays them.
    """
    t = np.arange(0.0, SECONDS + 1.0)
    north = np.stack([1.3 * t, 20.0 + 0 * t, 8.0 * t - 200.0], 1)
    east = np.stack([np.maximum(t - 30.0, 0.0), 1.1 * t, 5.0 + 0 * t], 1)
    present = np.ones((t.size, 3), dtype=bool)
    present[:10, 1] = False                 # 'late' appears at 10 s
    present[41:, 0] = False                 # 'early' leaves after 40 s
    lat, lon, _ = LocalTangentFrame(*MANHATTAN).to_geodetic(east, north)
    src = tmp_path / 'fcd.xml'
    write_fcd(src, t, ['early', 'late', 'car'], lat, lon, present)
    profile = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    profile['availability'] = {'outage_rate': 0.08, 'durations': [[2, 0.6], [5, 0.4]]}
    spec = tmp_path / 'ds5-outages.yaml'
    spec.write_text(yaml.safe_dump(profile))
    schedule = tmp_path / 'faults.yaml'
    schedule.write_text('faults:\n'
                        '  - {kind: outage, at: 20, duration: 5, agent: car}\n'
                        '  - {kind: frozen, at: 45, duration: 5, agent: late}\n'
                        '  - {kind: offset, at: 30, duration: 5, size_m: 25, bearing_deg: 90}\n')
    faults = ('--faults', str(schedule))
    got = in_ns3(str(spec), 5, tmp_path, ('--fcd', str(src), *faults))
    names = [str(n) for n in got['names']]
    assert names == ['early', 'car', 'late']          # in the order they first appear
    present = present[:, [['early', 'late', 'car'].index(n) for n in names]]
    err, pos = simulated(got, str(spec), 5, tmp_path, src, faults)
    assert not got['fix'][20:25, names.index('car')].any()
    fix = got['fix'] & present
    assert np.array_equal(fix, ~np.isnan(err[..., 0]))
    assert fix.any() and not fix[present].all()
    assert np.abs(got['error'][fix] - err[fix]).max() < TOL_M
    assert np.abs(got['position'][fix] - pos[fix]).max() < TOL_M

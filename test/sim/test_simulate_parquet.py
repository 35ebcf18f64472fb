"""
``gps_error simulate`` on SUMO's FCD as Parquet: the XML path's errors, bit for bit.

SUMO writes one scenario both ways (``--fcd-output fcd.xml`` and
``fcd.parquet``, lon/lat); the two outputs hold the same rows and the same
errors to the last bit. Then the Parquet path's refusals, and its parts
on a local Dask cluster against the whole file's output.
"""

import glob
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from gps_error_ros.cli import main as gps_error
from gps_error_ros.model.geodesy import difference
from gps_error_ros.sim.sumo_scenario import sumo_tool


@pytest.fixture(scope='module')
def sumo_both(tmp_path_factory):
    """Run SUMO on one scenario, writing its FCD as XML and as Parquet (lon/lat), from 0 s."""
    out = tmp_path_factory.mktemp('scen')
    assert gps_error(['scenario', str(out), '--until', '20', '--period', '1']) == 0
    for name in ('fcd.xml', 'fcd.parquet', 'fcd_xy.parquet'):
        geo = [] if name == 'fcd_xy.parquet' else ['--fcd-output.geo', 'true']
        done = subprocess.run([sumo_tool('sumo'), '-c', 'grid.sumocfg', '--begin', '0',
                               '--end', '90', '--fcd-output', name, '--no-step-log', *geo],
                              cwd=out, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
    return out


def xml_rows(path):
    """Return {(time, id): attributes} of an FCD XML file."""
    return {(float(ts.get('time')), c.get('id')): c.attrib
            for ts in ET.parse(path).getroot() for c in ts}


def run(*argv):
    return gps_error(['simulate', '--seed', '11', *argv])


@pytest.mark.parametrize('profile', ['DS5', 'phone-suburban-drive'])
def test_sumo_parquet_gets_the_xml_paths_errors_bit_for_bit(sumo_both, tmp_path, profile):
    d = sumo_both
    assert run('--profile', profile, '--trajectories', str(d / 'fcd.xml'), '--out',
               str(tmp_path / 'o.xml'), '--errors') == 0
    assert run('--profile', profile, '--trajectories', str(d / 'fcd.parquet'), '--out',
               str(tmp_path / 'o.parquet'), '--coordinates', 'lonlat', '--errors') == 0
    xml = xml_rows(tmp_path / 'o.xml')
    table = pq.read_table(tmp_path / 'o.parquet')
    rows = table.to_pylist()
    source = pq.read_table(d / 'fcd.parquet')
    assert table.num_rows == source.num_rows > 500          # every row carried through
    assert table.select(source.column_names).drop_columns(['person_x', 'person_y']).equals(
        source.drop_columns(['person_x', 'person_y']))      # SUMO's columns unchanged
    # SUMO's XML has an empty timestep at 0, its Parquet a row with no agent: the run
    # starts at the first timestep with somebody in it, in both
    assert rows[0]['person_id'] is None and rows[0]['fix'] is None
    assert min(t for t, _ in xml) == min(r['timestep_time'] for r in rows if r['fix']) > 0
    fixes = [r for r in rows if r['fix']]
    assert {(r['timestep_time'], r['person_id']) for r in fixes} == set(xml)
    for r in fixes:
        a = xml[r['timestep_time'], r['person_id']]
        for k in ('error_north', 'error_east'):
            assert float(a[k]) == r[k], (r, a)             # the same double
        for k in ('accuracy', 'accuracy_major', 'accuracy_minor', 'accuracy_orientation'):
            assert a[k] == f'{r[k]:.3f}', (k, r, a)
        # the truth differs (XML rounds it to 1e-6 degrees, about 0.1 m), the error added
        # to it does not (the speed, measured on that truth, differs: the next test)
        assert abs(float(a['x']) - r['person_x']) < 2e-6
        assert abs(float(a['y']) - r['person_y']) < 2e-6
    if profile == 'phone-suburban-drive':
        assert sum(r['reported_speed'] is not None for r in fixes) > 300


def test_the_same_truth_gives_every_column_of_the_xml_path(sumo_both, tmp_path):
    """The XML's own values as Parquet: positions, speed and accuracy, digit for digit."""
    xml = xml_rows(sumo_both / 'fcd.xml')
    keys = sorted(xml)
    pq.write_table(pa.table({
        'timestep_time': [k[0] for k in keys], 'person_id': [k[1] for k in keys],
        'person_x': [float(xml[k]['x']) for k in keys],
        'person_y': [float(xml[k]['y']) for k in keys],
        'person_edge': [xml[k]['edge'] for k in keys]}), tmp_path / 'same.parquet')
    common = ['--profile', 'phone-suburban-drive', '--covariance-mode', 'conditional']
    assert run('--trajectories', str(sumo_both / 'fcd.xml'), '--out', str(tmp_path / 'o.xml'),
               '--digits', '15', *common) == 0
    assert run('--trajectories', str(tmp_path / 'same.parquet'), '--out',
               str(tmp_path / 'o.parquet'), '--coordinates', 'lonlat', *common) == 0
    want = xml_rows(tmp_path / 'o.xml')
    got = [r for r in pq.read_table(tmp_path / 'o.parquet').to_pylist() if r['fix']]
    assert len(got) == len(want) > 500
    speeds = 0
    for r in got:
        a = want[r['timestep_time'], r['person_id']]
        assert (a['x'], a['y']) == (f'{r["person_x"]:.15f}', f'{r["person_y"]:.15f}'), (r, a)
        assert a['accuracy_major'] == f'{r["accuracy_major"]:.3f}'
        if 'reported_speed' in a:
            speeds += 1
            assert a['reported_speed'] == f'{r["reported_speed"]:.3f}'
            assert a['reported_bearing'] == f'{r["reported_bearing"]:.2f}'
        else:
            assert r['reported_speed'] is None
    assert speeds > 300


def test_metres_of_the_network_also_get_lon_lat(sumo_both, tmp_path):
    d = sumo_both
    assert run('--trajectories', str(d / 'fcd_xy.parquet'), '--out', str(tmp_path / 'o.parquet'),
               '--net', str(d / 'grid.net.xml'), '--errors') == 0
    table = pq.read_table(tmp_path / 'o.parquet')
    geo = pq.read_table(d / 'fcd.parquet')
    assert {'lon', 'lat'} <= set(table.column_names)
    # the noisy lon/lat lie the error away from SUMO's own lon/lat of the same rows
    got = difference(table.column('lat').to_numpy(), table.column('lon').to_numpy(),
                     geo.column('person_y').to_numpy(), geo.column('person_x').to_numpy())
    ok = ~np.isnan(table.column('lat').to_numpy())
    assert ok.sum() > 500
    np.testing.assert_allclose(np.asarray(got[0])[ok],
                               table.column('error_north').to_numpy()[ok], atol=0.01)
    np.testing.assert_allclose(np.asarray(got[1])[ok],
                               table.column('error_east').to_numpy()[ok], atol=0.01)


def test_outages_leave_the_row_with_no_position(tmp_path):
    from gps_error_ros.model.profiles import builtin_dir
    import yaml
    raw = yaml.safe_load((builtin_dir() / 'DS5.yaml').read_text())
    raw['availability'] = {'outage_rate': 0.05, 'durations': [[2, 0.5], [5, 0.5]]}
    prof = tmp_path / 'gappy.yaml'
    prof.write_text(yaml.safe_dump(raw))
    t = np.repeat(np.arange(100.0), 3)
    ids = ['a', 'b', 'c'] * 100
    pq.write_table(pa.table({'timestep_time': t, 'person_id': ids,
                             'person_x': np.full(t.size, -73.99),
                             'person_y': np.full(t.size, 40.75)}), tmp_path / 'in.parquet')
    assert run('--profile', str(prof), '--trajectories', str(tmp_path / 'in.parquet'), '--out',
               str(tmp_path / 'o.parquet'), '--coordinates', 'lonlat') == 0
    table = pq.read_table(tmp_path / 'o.parquet')
    fix = table.column('fix').to_numpy(zero_copy_only=False)
    assert 0 < (~fix).sum() < fix.size
    assert table.filter(pa.array(~fix)).column('person_x').null_count == (~fix).sum()
    assert table.filter(pa.array(~fix)).column('accuracy').null_count == (~fix).sum()
    assert table.filter(pa.array(fix)).column('person_x').null_count == 0


def test_bad_parquet_is_refused_by_name_and_leaves_no_output(sumo_both, tmp_path, capsys):
    good = (sumo_both / 'fcd.parquet').read_bytes()
    cases = {
        'cut.parquet': good[:len(good) // 2],
        'torn.parquet': good[:len(good) // 2] + good[-len(good) // 3:],
        'text.parquet': b'timestep_time,person_id\n1,p0\n',
    }
    for name, data in cases.items():
        (tmp_path / name).write_bytes(data)
    backwards = tmp_path / 'backwards.parquet'
    pq.write_table(pa.table({'timestep_time': [2.0, 1.0], 'person_id': ['a', 'a'],
                             'person_x': [-73.99, -73.99], 'person_y': [40.75, 40.75]}),
                   backwards)
    nocols = tmp_path / 'nocols.parquet'
    pq.write_table(pa.table({'time': [1.0], 'id': ['a']}), nocols)
    want = {'cut.parquet': 'not a readable Parquet file',
            'torn.parquet': 'corrupt or truncated',
            'text.parquet': 'not a readable Parquet file',
            'backwards.parquet': 'expected rows in time order',
            'nocols.parquet': "no column 'timestep_time'"}
    for name, said in want.items():
        out = tmp_path / f'out-{name}'
        assert run('--trajectories', str(tmp_path / name), '--out', str(out),
                   '--coordinates', 'lonlat') == 2, name
        err = capsys.readouterr().err
        assert name in err and said in err, err
        assert not out.exists() and not glob.glob(str(tmp_path / f'.out-{name}*'))
    # what SUMO's Parquet cannot say is asked for
    assert run('--trajectories', str(sumo_both / 'fcd.parquet'), '--out',
               str(tmp_path / 'o.parquet')) == 2
    assert '--coordinates lonlat' in capsys.readouterr().err
    assert run('--trajectories', str(sumo_both / 'fcd.parquet'), '--out',
               str(tmp_path / 'o.xml'), '--coordinates', 'lonlat') == 2
    assert 'Parquet in, Parquet out' in capsys.readouterr().err


def test_parts_on_a_local_dask_cluster_give_the_whole_files_output(sumo_both, tmp_path,
                                                                   capsys):
    src = sumo_both / 'fcd.parquet'
    common = ['--profile', 'phone-suburban-drive', '--coordinates', 'lonlat', '--errors']
    assert run('--trajectories', str(src), '--out', str(tmp_path / 'whole.parquet'),
               *common) == 0
    assert gps_error(['split', '--trajectories', str(src), '--parts', '3', '--out',
                      str(tmp_path / 'parts')]) == 0
    parts = sorted(glob.glob(str(tmp_path / 'parts' / '*.parquet')))
    assert len(parts) == 3 and all(pq.read_metadata(p).num_rows for p in parts)
    capsys.readouterr()
    assert run('--trajectories', str(tmp_path / 'parts'), '--out', str(tmp_path / 'out'),
               '--workers', '2', *common) == 0
    assert '3 parts' in capsys.readouterr().out
    whole = pq.read_table(tmp_path / 'whole.parquet')
    split = pa.concat_tables([pq.read_table(p) for p in
                              sorted(glob.glob(str(tmp_path / 'out' / '*.parquet')))])

    def ordered(t):
        key = np.lexsort((np.array([v or '' for v in t.column('person_id').to_pylist()]),
                          t.column('timestep_time').to_numpy()))
        return t.take(pa.array(key))

    assert split.num_rows == whole.num_rows
    assert ordered(split).equals(ordered(whole))       # every column, every bit

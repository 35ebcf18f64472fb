"""``gps_error scenario``: a georeferenced SUMO scenario whose FCD simulate reads as lon/lat."""

from gps_error_ros.cli import main as gps_error
from gps_error_ros.traces.trajectories import fcd_coordinates, NetProjection


def test_scenario_runs_sumo_and_simulate_reads_its_fcd(tmp_path, capsys):
    out = tmp_path / 'scen'
    assert gps_error(['scenario', str(out), '--lat', '51.7', '--lon', '-1.25',
                      '--until', '10', '--fcd', '40']) == 0
    said = capsys.readouterr().out
    assert 'persons.rou.xml' in said and 'fcd.xml (lon/lat)' in said, said
    assert NetProjection(out / 'grid.net.xml').geo            # the grid has a projection
    assert fcd_coordinates(out / 'fcd.xml') == 'lonlat'
    noisy = tmp_path / 'noisy.xml'
    assert gps_error(['simulate', '--profile', 'DS5', '--seed', '1', '--trajectories',
                      str(out / 'fcd.xml'), '--out', str(noisy)]) == 0
    said = capsys.readouterr().out
    assert '40 timesteps' in said and ' 0 positions' not in said, said
    lon = [float(v.split('"')[1]) for v in noisy.read_text().split(' x=')[1:]]
    assert lon and all(-1.26 < v < -1.24 for v in lon)       # placed where asked


def test_without_fcd_it_prints_the_sumo_command(tmp_path, capsys):
    assert gps_error(['scenario', str(tmp_path / 's'), '--until', '4']) == 0
    said = capsys.readouterr().out
    assert '--fcd-output.geo true --end SECONDS' in said, said

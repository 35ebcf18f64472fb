"""
The core and every `gps_error` command run without ROS.

The commands: calibrate, validate, simulate, synth, diagnose and import.

Each command runs in a fresh interpreter whose import system refuses rclpy
and every ROS message package, as in an environment with only
`pip install` of this package.
"""

import subprocess
import sys
import textwrap

import numpy as np

from trace_helpers import synthetic_trace, write_csv

BLOCK = textwrap.dedent('''
    import importlib.abc, sys
    BLOCKED = ('rclpy', 'rosidl', 'rcl_interfaces', 'builtin_interfaces',
               'sensor_msgs', 'geometry_msgs', 'nav_msgs', 'std_srvs',
               'rosgraph_msgs', 'std_msgs', 'ament_index_python')

    class NoRos(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split('.')[0] in BLOCKED:
                raise ImportError(f'{name} is not available (no ROS here)')
            return None

    sys.meta_path.insert(0, NoRos())
    from gps_error_ros.cli import main
    raise SystemExit(main(sys.argv[1:]))
''')


def run(*args):
    return subprocess.run([sys.executable, '-c', BLOCK, *args],
                          capture_output=True, text=True, timeout=300)


def test_blocker_blocks():
    r = subprocess.run([sys.executable, '-c', BLOCK.replace(
        'from gps_error_ros.cli import main', 'import rclpy')],
        capture_output=True, text=True)
    assert r.returncode != 0 and 'no ROS here' in r.stderr


def test_commands_without_ros(tmp_path):
    trace, _ = synthetic_trace(900, seed=3)
    csv = tmp_path / 'walk.csv'
    write_csv(csv, trace)
    r = run('calibrate', str(csv), '-o', str(tmp_path / 'p.yaml'))
    assert r.returncode == 0, r.stderr
    r = run('validate', str(tmp_path / 'p.yaml'), str(csv), '--out',
            str(tmp_path / 'v'), '--sims', '20')
    assert r.returncode == 0, r.stderr
    r = run('simulate', '--profile', 'DS2', '--seed', '1', '--agents', '3',
            '--duration', '20', '--out', str(tmp_path / 'e.npz'))
    assert r.returncode == 0, r.stderr
    assert np.load(tmp_path / 'e.npz')['errors'].shape == (3, 20, 2)
    truth = tmp_path / 'truth.csv'
    truth.write_text('t,truth_lat,truth_lon\n0,40.0,-74.0\n1,40.0,-74.0\n')
    r = run('simulate', '--seed', '1', '--trajectories', str(truth),
            '--out', str(tmp_path / 'noisy.csv'))
    assert r.returncode == 0, r.stderr
    walk = tmp_path / 'synth.csv'
    r = run('synth', 'multipath', '-o', str(walk), '--seed', '2', '--duration', '1200')
    assert r.returncode == 0, r.stderr
    r = run('diagnose', str(walk), '--json', str(tmp_path / 'd.json'),
            '--profile-out', str(tmp_path / 'x.yaml'), '--sims', '20')
    assert r.returncode == 0, r.stderr
    r = run('simulate', '--profile', str(tmp_path / 'x.yaml'), '--seed', '1',
            '--agents', '2', '--duration', '10', '--out', str(tmp_path / 'x.npz'))
    assert r.returncode == 0, r.stderr
    from measured import RAW as raw
    r = run('import', 'nmea', str(raw / 'gsdc2020-mtv1' / 'Pixel4_chipset.nmea'),
            '--truth', '37.42,-122.09', '-o', str(tmp_path / 'imported.csv'))
    assert r.returncode == 0, r.stderr

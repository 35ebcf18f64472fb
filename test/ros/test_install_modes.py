"""
Profiles are found, and the node runs, in every install mode.

Editable (`pip install -e .`, what `make` does), `pip install .` (here into a
separate --prefix) and colcon (`colcon build` + `install/setup.bash`, as in a
ROS 2 workspace). Each mode runs in a fresh interpreter outside the source
tree, so nothing leaks in from the checkout.
"""

import os
from pathlib import Path
import subprocess
import sys

import pytest

from gps_error_ros.model.profiles import load_profile

REPO = Path(__file__).resolve().parents[2]
VENV_BIN = Path(sys.executable).parent
PROBE = ('import gps_error_ros, gps_error_ros.model.profiles as p; '
         'print(gps_error_ros.__file__); print(p.load_profile("ds5").path); '
         'print(p.load_profile("DS7").model().stationary_sd.round(3).tolist())')


#: What the probe prints last: DS7's stationary SD, from the profile in this checkout.
DS7_SD = load_profile('DS7').model().stationary_sd.round(3).tolist()


def _run(cmd, cwd, env, timeout=300):
    out = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True,
                         timeout=timeout)
    assert out.returncode == 0, out.stdout + out.stderr
    return out.stdout.strip().splitlines()


def _clean_env(**extra):
    env = {k: v for k, v in os.environ.items()
           if k not in ('PYTHONPATH', 'AMENT_PREFIX_PATH')}
    env.update(extra)
    return env


def test_editable(tmp_path):
    lines = _run([sys.executable, '-c', PROBE], tmp_path, _clean_env())
    assert lines[0].startswith(str(REPO))
    assert lines[1] == str(REPO / 'config' / 'profiles' / 'DS5.yaml')
    assert lines[2] == repr(DS7_SD)


@pytest.mark.parametrize('with_ament', [False, True])
def test_pip_install_non_editable(tmp_path, with_ament):
    prefix = tmp_path / 'prefix'
    # --ignore-installed: without it pip uninstalls the venv's editable
    # install (and its console scripts) before installing into --prefix.
    _run([sys.executable, '-m', 'pip', 'install', '--quiet', '--no-deps',
          '--ignore-installed', '--disable-pip-version-check', '--prefix',
          str(prefix), str(REPO)], tmp_path, _clean_env())
    site = next(prefix.glob('lib/python*/site-packages'))
    env = _clean_env(PYTHONPATH=str(site))
    if with_ament:
        env['AMENT_PREFIX_PATH'] = str(prefix)
    lines = _run([sys.executable, '-c', PROBE], tmp_path, env)
    assert lines[0].startswith(str(site))
    assert lines[1] == str(prefix / 'share' / 'gps_error_ros' / 'config'
                           / 'profiles' / 'DS5.yaml')
    assert (prefix / 'share' / 'ament_index' / 'resource_index' / 'packages'
            / 'gps_error_ros').exists()


def test_colcon_build_and_run(tmp_path):
    ws = tmp_path / 'ws'
    (ws / 'src').mkdir(parents=True)
    (ws / 'src' / 'gps_error_ros').symlink_to(REPO)
    env = _clean_env(AMENT_PREFIX_PATH=str(VENV_BIN.parent),
                     PATH=f'{VENV_BIN}:{os.environ["PATH"]}')
    _run([str(VENV_BIN / 'colcon'), 'build', '--packages-select', 'gps_error_ros',
          '--build-base', str(ws / 'build'), '--install-base', str(ws / 'install')],
         ws, env)
    exe = ws / 'install' / 'gps_error_ros' / 'lib' / 'gps_error_ros' / 'gps_error_node'
    assert exe.exists(), 'ros2 run looks for the executable in lib/<package>'
    sourced = f'. {ws}/install/setup.bash && '
    lines = _run(['bash', '-c', sourced + f'python -c \'{PROBE}\''], tmp_path, env)
    assert lines[0].startswith(str(ws / 'install'))
    assert lines[1] == str(ws / 'install' / 'gps_error_ros' / 'share' /
                           'gps_error_ros' / 'config' / 'profiles' / 'DS5.yaml')
    # The installed executable starts and applies its parameters: a bad one
    # makes it exit 2 naming the parameter (a good one would spin forever).
    out = subprocess.run(
        ['bash', '-c', sourced + f'{exe} --ros-args -p profile:=DS4'],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 2, out.stdout + out.stderr
    assert "'profile'" in out.stdout + out.stderr

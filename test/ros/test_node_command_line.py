"""What a user types: integers for numbers, typos, --help, unparsable lists."""

import subprocess
import time

import pytest

from ros_harness import node_executable, NodeProcess, unique_ns

pytestmark = pytest.mark.integration


def run_briefly(args, name='gps_error_node', seconds=4.0):
    """Start a node, let it come up, Ctrl-C it; return (exit code, output)."""
    node = NodeProcess(['--ros-args', '-r', f'__ns:={unique_ns()}'] + args, name=name)
    end = time.monotonic() + seconds
    while time.monotonic() < end and node.proc.poll() is None:
        time.sleep(0.1)
    return node.stop()


def test_integers_are_accepted_for_numbers(tmp_path):
    rc, out = run_briefly(['-p', 'rate:=2', '-p', 'datum:=[40, -73, 0]'])
    assert rc == 0 and 'fixes at 2.0 Hz' in out, out
    params = tmp_path / 'p.yaml'
    params.write_text('/**:\n  ros__parameters:\n    rate: 4\n    max_pose_age: 2\n'
                      '    datum: [40, -73, 0]\n')
    rc, out = run_briefly(['--params-file', str(params)])
    assert rc == 0 and 'fixes at 4.0 Hz' in out, out


def test_an_unknown_parameter_is_named(tmp_path):
    rc, out = run_briefly(['-p', 'rat:=2.0', '-p', 'datum:=[40.0, -73.0, 0.0]'])
    assert rc == 0 and 'unknown parameter(s) rat ignored' in out, out


@pytest.mark.parametrize('name', ['gps_error_node', 'gps_calibration_node'])
def test_help_prints_parameters_topics_and_an_example(name):
    r = subprocess.run(node_executable(name) + ['--help'], capture_output=True,
                       text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    for text in ('parameters:', 'topics:', 'example:', 'input_type', 'datum'):
        assert text in r.stdout
    assert '[INFO]' not in r.stdout + r.stderr           # ROS never started


def test_a_list_rcl_cannot_parse_is_one_line_and_exit_2():
    r = subprocess.run(node_executable('gps_error_node') + [
        '--ros-args', '-p', 'datum:=[40.75, -73.99, 0]'], capture_output=True,
        text=True, timeout=30)
    assert r.returncode == 2
    assert 'Traceback' not in r.stderr
    assert 'cannot parse the command line' in r.stderr and '0.0' in r.stderr

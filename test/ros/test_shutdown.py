"""
Ctrl-C always ends a node with exit 0, after its shutdown work, and quietly.

Run twice where the moment of the signal varies, because the failures
guarded against were races (a signal arriving while the executor built its
wait set: two runs in three; a KeyboardInterrupt inside an rclpy Task).
"""

import csv
import re
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest

from bag_helpers import write_walk_bag
from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.ros.bag_play import play
from gps_error_ros.ros.lifecycle import QUICK_EXIT_PUBLISHERS
from ros_harness import DATUM_ARG, Peer, replay_calibration_node, start, unique_ns

pytestmark = pytest.mark.integration
NOISE = ('Traceback', 'RCLError', 'Failed to publish log message to rosout')


def wait_up(peer, name, ns, timeout=20):
    """
    Wait until node ``name`` in namespace ``ns`` is built (its services exist).

    A signal that arrives while a node is still being built ends it before
    it has received anything; exit 0 with nothing to write is right then, but
    not what these tests are about: after the graph shows the node, a second
    passes, so that its constructor has surely returned.
    """
    if name == 'gps_error_node':           # its fix publisher comes last
        up = peer.spin_until(lambda: peer.node.count_publishers(f'{ns}/fix') > 0,
                             timeout)
    else:                                  # the calibration node's service does
        service = f'{ns}/{name}/calibrate'
        up = peer.spin_until(lambda: any(
            s == service for s, _ in peer.node.get_service_names_and_types()), timeout)
    peer.spin_for(1.0)
    return up


def rows(path):
    """Return the data rows of a CSV file."""
    with open(path) as f:
        return list(csv.DictReader(f))


def assert_clean_exit(rc, log):
    """Exit 0 and none of the noise a clean shutdown must not print."""
    assert rc == 0, log
    for text in NOISE:
        assert text not in log, log


@pytest.fixture(scope='module')
def bag(tmp_path_factory):
    model = ARErrorModel(AxisParams(0.2, (0.9,), 0.5), AxisParams(0.0, (0.7,), 0.6))
    n = 150
    err = model.simulate(streams.agent_key(3), n)[:, 0]
    path = tmp_path_factory.mktemp('bag') / 'rec'
    write_walk_bag(path, 'mcap', (40.0, -74.0, 0.0), err, 500.0 + np.arange(n),
                   truth_rate=2.0)
    return path


def test_calibration_node_without_data(tmp_path):
    out = tmp_path / 'nothing.yaml'
    ns = unique_ns()
    node = replay_calibration_node(ns, out)
    peer = Peer()
    try:
        assert wait_up(peer, 'gps_calibration_node', ns)
        assert_clean_exit(*node.stop())
    finally:
        peer.destroy()
    assert not out.exists()
    for suffix in ('.fixes.csv', '.truth.csv', '.trace.csv'):
        assert rows(tmp_path / f'nothing{suffix}') == []


@pytest.mark.parametrize('run', range(2))
def test_calibration_node_after_a_replay(tmp_path, bag, run):
    out = tmp_path / 'replayed.yaml'
    node = replay_calibration_node(unique_ns(), out)
    peer = Peer()
    try:
        play(bag, rate=50.0, wait_for_subscribers=1, node=peer.node)
        peer.spin_for(0.5)
        rc, log = node.stop()
    finally:
        peer.destroy()
    assert_clean_exit(rc, log)
    # what the node paired is written (a fast replay may lose a few messages
    # on the best-effort inputs; that is not this test's subject)
    assert out.exists() and 100 <= len(rows(tmp_path / 'replayed.trace.csv')) <= 150


@pytest.mark.parametrize('run', range(2))
def test_calibration_node_during_a_replay(tmp_path, bag, run):
    out = tmp_path / 'cut.yaml'
    ns = unique_ns()
    node = replay_calibration_node(ns, out)
    peer = Peer()
    timer = threading.Timer(1.0 + 0.5 * run, node.proc.send_signal, (signal.SIGINT,))
    try:
        assert wait_up(peer, 'gps_calibration_node', ns)
        timer.start()
        play(bag, rate=20.0, wait_for_subscribers=1, node=peer.node)
        rc, log = node.stop()
    finally:
        timer.cancel()
        peer.destroy()
    assert_clean_exit(rc, log)
    received = rows(tmp_path / 'cut.fixes.csv')
    assert 0 < len(received) < 150          # cut short, and kept what came
    assert (tmp_path / 'cut.trace.csv').exists()


@pytest.mark.parametrize('run', range(2))
def test_error_node_ctrl_c(run):
    ns = unique_ns()
    node = start(ns, DATUM_ARG, 'seed:=1')
    peer = Peer()
    try:
        assert wait_up(peer, 'gps_error_node', ns)
        peer.spin_for(0.5 * run)
        rc, log = node.stop()
    finally:
        peer.destroy()
    assert_clean_exit(rc, log)
    assert 'at shutdown:' in log


def test_a_crowd_node_ends_at_once_after_its_summary():
    """Past QUICK_EXIT_PUBLISHERS the process ends without destroying its topics."""
    ns = unique_ns()
    n = QUICK_EXIT_PUBLISHERS + 50
    names = ', '.join(f'"a{i}"' for i in range(n))
    node = start(ns, DATUM_ARG, 'seed:=1', f'agents:=[{names}]')
    peer = Peer()
    try:
        assert peer.spin_until(
            lambda: peer.node.count_publishers(f'{ns}/a{n - 1}/fix') > 0, 60), node.stop()[1]
        peer.spin_for(1.0)
        rc, log = node.stop()
    finally:
        peer.destroy()
    assert_clean_exit(rc, log)
    # the summary is written before the process ends, and then why it ends so
    ending = re.search(r'ending without destroying its (\d+) publishers one by one', log)
    assert ending and int(ending.group(1)) > n, log       # its fixes, /rosout, ...
    assert 0 <= log.find('at shutdown:') < ending.start(), log


SPIN_PAST_UNTAKEABLE = '''
import os, signal, sys
from rclpy.node import Node
from gps_error_ros.ros import lifecycle

class Ticker(Node):
    def __init__(self):
        super().__init__('ticker')
        self.ticks = 0
        self.create_timer(0.02, self.tick)

    def tick(self):
        self.ticks += 1
        if self.ticks == 3:          # what rclpy raises when it cannot build a taken message
            raise RuntimeError(lifecycle.UNTAKEABLE + " '0' to Python object")
        if self.ticks == 10:
            os.kill(os.getpid(), signal.SIGINT)
        if self.ticks == 4 and DEFECT:
            raise ValueError('a defect of ours')

DEFECT = sys.argv[1] == 'defect'
code = lifecycle.run_node(Ticker, 'ticker', [])
print('exit', code)
sys.exit(code)
'''


def test_a_message_rclpy_cannot_take_is_dropped_and_spinning_goes_on():
    """The node's spin outlives rclpy's conversion error; our own errors still stop it."""
    def run(case):
        done = subprocess.run([sys.executable, '-c', SPIN_PAST_UNTAKEABLE, case],
                              capture_output=True, text=True, timeout=60)
        return done.returncode, done.stdout + done.stderr

    rc, out = run('clean')
    assert 'could not be taken from the middleware and was dropped' in out, out
    assert rc == 0 and 'exit 0' in out, out          # ticked on to the SIGINT at tick 10
    # a defect of ours is not swallowed: the node stops on it, with its traceback
    rc, out = run('defect')
    assert rc != 0 and 'ValueError: a defect of ours' in out, out


SPIN_AFTER_A_STOP = """
import sys
import rclpy
from gps_error_ros.ros import lifecycle
rclpy.init()
node = rclpy.create_node('spin_after_a_stop')
rclpy.shutdown()                              # the stop came while the node was built
if sys.argv[1] == 'none':                     # rclpy's executor went with the context
    rclpy.get_global_executor = lambda: None
lifecycle._spin(node, rclpy.logging.get_logger('spin_after_a_stop'))
node.destroy_node()
print('spin returned')
"""


@pytest.mark.parametrize('case', ['shut', 'none'])
def test_a_stop_before_spinning_ends_the_node_cleanly(case):
    """Seen on a loaded machine: SIGINT right after the start-up line, exit status 1."""
    done = subprocess.run([sys.executable, '-c', SPIN_AFTER_A_STOP, case],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and 'spin returned' in done.stdout, done.stderr

"""
The pedestrian-to-vehicle study runs end to end in real ns-3, short (``make p2v`` runs it long).

``python -m gps_error_ros.ns3.p2v`` as a user runs it: pedestrians' phones
broadcast safety messages over 802.11p, vehicles warn from what they
receive, once with no errors, once with white noise of DS5's size and once
with DS5. What the run must show whatever the machine: every condition
sent and lost the same packets (the radio moves with the truth), the
messages' positions are off by what each condition's errors say, the
warnings add up, and the figure is a PNG.
"""

import json
import subprocess
import sys

import numpy as np


def run_p2v(*argv, timeout=900):
    """Run the study's command; return the finished process."""
    return subprocess.run([sys.executable, '-m', 'gps_error_ros.ns3.p2v', *argv],
                          capture_output=True, text=True, timeout=timeout)


def test_a_short_study(tmp_path):
    """Twelve pedestrians, four vehicles, 12 s at 10 Hz, three conditions."""
    run = run_p2v('--pedestrians', '12', '--vehicles', '4', '--duration', '12',
                  '--conditions', 'none,white:DS5,DS5', '--jobs', '2', '--out', str(tmp_path))
    assert run.returncode == 0, run.stderr[-3000:]
    assert '| DS5 |' in run.stdout
    assert (tmp_path / 'p2v.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    res = json.loads((tmp_path / 'p2v.json').read_text())
    conds = res['conditions']
    assert list(conds) == ['none', 'white:DS5', 'DS5']
    assert len({c['rx_digest'] for c in conds.values()}) == 1, 'the network differed'
    for c in conds.values():
        # each pedestrian sends from a random offset in the first 0.1 s, every 0.1 s, to 12 s
        assert 12 * 120 <= c['messages_sent'] <= 12 * 121
        assert c['messages_without_fix'] == 0
        assert c['hits'] + c['misses'] == c['encounters']
        assert c['false_warnings'] <= c['warnings']
        assert all(0.0 < b < 1.0 for b in c['channel_busy'])
        sent, got = np.array(c['pdr_sent']), np.array(c['pdr_delivered'])
        assert (got <= sent).all() and got[0] / sent[0] > 0.8
    # a fix a second: a message is up to a second old, a walker does 1.6 m/s at most
    assert conds['none']['message_error_m']['p95'] < 1.7
    assert conds['DS5']['message_error_m']['median'] > 4.0
    assert conds['white:DS5']['message_error_m']['median'] > 4.0


def test_an_unknown_profile_stops_before_any_world_runs(tmp_path):
    """A condition naming no profile is refused with its name, and nothing is written."""
    run = run_p2v('--conditions', 'none,DS55', '--out', str(tmp_path / 'out'), timeout=120)
    assert run.returncode == 2
    assert 'DS55' in run.stderr
    assert not (tmp_path / 'out').exists()

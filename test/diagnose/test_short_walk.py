"""The shortest visible walk (five minutes) through diagnose and compare, as a user runs them."""

import subprocess
import sys

import numpy as np
import pytest

from gps_error_ros.diagnose.mean import MAX_RADIUS, stationary_phi
from gps_error_ros.model.ar_model import inverse_root_modulus
from gps_error_ros.traces.trace_io import read_trace_csv
from measured import WALKS


@pytest.mark.parametrize('command', ['diagnose', 'compare'])
def test_the_shortest_walk_is_diagnosed_and_compared(command, tmp_path):
    walk = min(WALKS, key=lambda p: len(read_trace_csv(p)))
    proc = subprocess.run([sys.executable, '-m', 'gps_error_ros.cli', command, str(walk),
                           '--sims', '20', '--json', str(tmp_path / 'out.json')],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == '' and 'Warning' not in proc.stdout, proc.stderr
    assert 'gross failure' in proc.stdout          # its failure is found and left out
    assert (tmp_path / 'out.json').stat().st_size > 0


def test_a_fitted_ar_part_outside_stationarity_is_pulled_inside_keeping_its_shape():
    phi = np.array([1.3, -0.2, -0.05])
    assert inverse_root_modulus(phi) > 1.0
    inside = stationary_phi(phi)
    assert inverse_root_modulus(inside) == pytest.approx(MAX_RADIUS, abs=1e-9)
    # the same roots scaled: phi_i c**i with one c
    c = inside / phi
    assert c[1] == pytest.approx(c[0] ** 2) and c[2] == pytest.approx(c[0] ** 3)
    fine = np.array([0.6, 0.2])
    assert stationary_phi(fine) is fine

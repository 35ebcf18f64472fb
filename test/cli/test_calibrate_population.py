"""``gps_error calibrate --population``: a profile of the receiver across recordings."""

import re

import numpy as np
import yaml

from gps_error_ros.cli import main as cli
from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.model.geodesy import LocalTangentFrame
from gps_error_ros.model.population import WithPopulation
from gps_error_ros.model.profiles import load_profile_file
from gps_error_ros.traces.trace_io import Trace, write_trace_csv

#: A phone-like process: AR(1), phi 0.9 (a 300 s mean's SD about 0.6 m).
PHONE = ARErrorModel(AxisParams(0.0, (0.9,), 1.0), AxisParams(0.0, (0.9,), 1.0))


def _recording(tmp_path, seed, seconds, shift_m=0.0):
    """Write a standing phone's recording with this run's own north bias ``shift_m``."""
    err = PHONE.simulate(streams.agent_key(seed, 'run'), seconds)[:, 0]
    err[:, 0] += shift_m
    frame = LocalTangentFrame(40.75, -73.99, 0.0)
    lat, lon, _ = frame.to_geodetic(err[:, 1], err[:, 0], np.zeros(seconds))
    trace = Trace(name=f'run{seed}', t=np.arange(seconds, dtype=float), lat=lat, lon=lon,
                  truth_lat=np.full(seconds, 40.75), truth_lon=np.full(seconds, -73.99))
    return write_trace_csv(trace, tmp_path / f'run{seed}.csv')


def test_recordings_with_different_biases_give_a_population(tmp_path, capsys):
    paths = [_recording(tmp_path, s, 900, shift) for s, shift in
             ((1, -6.0), (2, 0.0), (3, 6.0), (4, -3.0), (5, 3.0))]
    out = tmp_path / 'phone.yaml'
    assert cli(['calibrate', *map(str, paths), '-o', str(out), '--population',
                '--within', 'ar']) == 0
    printed = capsys.readouterr().out
    assert re.search(r'population \(1[5-9] blocks of 300 s\)', printed), printed
    raw = yaml.safe_load(out.read_text())
    sd = raw['fit']['population']['bias_sd_estimate_m']
    # the runs' north biases have SD 4.7 m; the east ones differ by sampling alone
    assert 3.0 < sd[0] < 7.0 and sd[1] < 1.0, sd
    assert raw['fit']['population']['fitted'] is True
    # five runs (a little more: the fit lets the bias wander within a run):
    # a sixth's bias is t(4) about a mean known to 1/sqrt(k)
    k = raw['fit']['population']['independent_draws']
    assert 5.0 <= k < 5.5 and raw['population']['bias_dof'] == 4
    np.testing.assert_allclose(raw['population']['bias_sd_m'],
                               np.array(sd) * np.sqrt(1 + 1 / k) * np.sqrt(2.0), atol=2e-4)
    assert 'Student-t with 4 degrees of freedom' in printed, printed
    model = load_profile_file(out).model()
    assert isinstance(model, WithPopulation)
    # without --population the biases' spread goes into the one process instead
    plain = tmp_path / 'plain.yaml'
    assert cli(['calibrate', *map(str, paths), '-o', str(plain)]) == 0
    assert 'population' not in yaml.safe_load(plain.read_text())
    assert load_profile_file(plain).model().stationary_sd[0] > \
        np.sqrt(model.inner.stationary_cov[0, 0]) + 1.0


def test_too_little_data_writes_no_population_and_says_why(tmp_path, capsys):
    path = _recording(tmp_path, 1, 500)
    out = tmp_path / 'short.yaml'
    assert cli(['calibrate', str(path), '-o', str(out), '--population']) == 0
    printed = capsys.readouterr().out
    assert 'population: not fitted: 2 blocks of 300 s' in printed
    assert 'a population needs 3' in printed
    raw = yaml.safe_load(out.read_text())
    assert 'population' not in raw and raw['fit']['population']['fitted'] is False

"""``gps_error diagnose --profile-out --population``: the population profile of a recording."""

import numpy as np
import pytest
import yaml

from gps_error_ros.cli import main as cli
from gps_error_ros.fit.holdout import split_trace
from gps_error_ros.model.population import WithPopulation
from gps_error_ros.model.profiles import load_profile_file
from gps_error_ros.sim.synthetic import synthetic_trace
from gps_error_ros.traces.trace_io import read_trace_csv, write_trace_csv


def test_the_population_profile_is_written_and_loads(tmp_path, capsys):
    src = write_trace_csv(synthetic_trace('none', 3, 1800), tmp_path / 'walk.csv')
    out = tmp_path / 'pop.yaml'
    assert cli(['diagnose', str(src), '--profile-out', str(out), '--population',
                '--sims', '20']) == 0
    assert 'population: {' in capsys.readouterr().out
    raw = yaml.safe_load(out.read_text())
    assert set(raw['population']) >= {'bias_sd_m', 'scale_sd_log'}
    assert raw['fit']['population']['blocks'] >= 3
    model = load_profile_file(out).model()
    assert isinstance(model, WithPopulation)
    # its mean is the training part's mean error (delta written for it, 6 digits)
    train = np.concatenate(split_trace(read_trace_csv(src)).train.err).mean(axis=0)
    lag = raw.get('effects', {}).get('motion_lag')
    if lag is None:
        np.testing.assert_allclose(model.mean, train, atol=1e-3)


def test_population_without_a_profile_out_is_refused(tmp_path):
    src = write_trace_csv(synthetic_trace('none', 3, 600), tmp_path / 'walk.csv')
    with pytest.raises(SystemExit) as exc:
        cli(['diagnose', str(src), '--population'])
    assert '--population goes with --profile-out' in str(exc.value)


def test_too_few_blocks_write_the_extended_profile(tmp_path, capsys):
    src = write_trace_csv(synthetic_trace('none', 3, 600), tmp_path / 'walk.csv')
    out, ext = tmp_path / 'pop.yaml', tmp_path / 'ext.yaml'
    assert cli(['diagnose', str(src), '--profile-out', str(out), '--population',
                '--sims', '20']) == 0
    assert 'the extended profile is written' in capsys.readouterr().out
    assert cli(['diagnose', str(src), '--profile-out', str(ext), '--sims', '20']) == 0
    got, want = (yaml.safe_load(p.read_text()) for p in (out, ext))
    assert 'population' not in got
    assert {k: v for k, v in got.items() if k != 'name'} == \
        {k: v for k, v in want.items() if k != 'name'}

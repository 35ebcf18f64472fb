"""``calibrate --population``: the class judged best, fitted to every recording."""

from pathlib import Path

import pytest
import yaml

from gps_error_ros.cli import main as cli
from gps_error_ros.diagnose.pipeline import split_step
from gps_error_ros.fit.gross_failures import without_rows
from gps_error_ros.judge.generalise import population_profile
from gps_error_ros.judge.population_calibration import calibrate_best
from gps_error_ros.model.effects import ExtendedModel
from gps_error_ros.model.population import WithPopulation
from gps_error_ros.model.profiles import load_profile_file
from gps_error_ros.traces.loading import load_trace

DATA = Path(__file__).resolve().parents[2] / 'data'
PHONE = DATA / 'gsdc2020-mtv1-pixel4.csv'


def test_the_profile_is_the_class_the_folds_judged():
    # calibrate on a recording's first 70 % is, section for section, the
    # population class compare --folds and the generalisation page judge on
    # that split's training part (the allowance for other days aside)
    trace = load_trace(PHONE)[0]
    split = split_step(trace)
    judged = population_profile(split, 'phone', 'src', seed=0)
    first = without_rows(trace, trace.t >= trace.t[0] + split.cut_time_s)
    fitted = calibrate_best(first, day_allowance=0.0, seed=0).profile_dict('phone')
    assert judged['effects']                      # the extended model, not the AR alone
    for section in ('axes', 'effects', 'population'):
        assert fitted[section] == judged[section], section


def test_calibrate_population_writes_the_best_class(tmp_path, capsys):
    out = tmp_path / 'best.yaml'
    assert cli(['calibrate', str(PHONE), '--population', '-o', str(out)]) == 0
    printed = capsys.readouterr().out
    assert 'within the blocks: the extended model' in printed, printed
    raw = yaml.safe_load(out.read_text())
    # every effect a recording shows: the extended model's, velocity, the stated
    # accuracy, and the allowance for other days of a one-day population
    assert {'effects', 'population', 'velocity', 'reported_accuracy'} <= set(raw)
    assert raw['fit']['population']['within']['effects'] == list(raw['effects'])
    assert raw['population']['run_bias_sd_m'][0] == pytest.approx(
        raw['fit']['population']['between_days']['held_sd_m'], abs=1e-4)
    model = load_profile_file(out).model()
    assert isinstance(model, WithPopulation) and isinstance(model.inner, ExtendedModel)
    # the simpler class on request: the Gaussian AR within, no effects
    simple = tmp_path / 'simple.yaml'
    assert cli(['calibrate', str(PHONE), '--population', '--within', 'ar',
                '-o', str(simple)]) == 0
    raw = yaml.safe_load(simple.read_text())
    assert 'population' in raw and 'effects' not in raw


@pytest.mark.parametrize('args, said', [
    (['--population', '--order', '3'], '--order 3 fixes the Gaussian AR\'s order'),
    (['--within', 'ar'], '--within ar is the process within a population\'s blocks'),
])
def test_options_that_do_not_go_together_are_refused(tmp_path, capsys, args, said):
    out = tmp_path / 'p.yaml'
    assert cli(['calibrate', str(PHONE), *args, '-o', str(out)]) == 2
    assert said in capsys.readouterr().err and not out.exists()

"""A population from one occasion: it says what it cannot know, and allows for other days."""

import math

import pytest

from gps_error_ros.cli import main as cli
from gps_error_ros.fit.population_fit import DAY_RATIO, ONE_OCCASION_NOTE
from gps_error_ros.model.profiles import load_profile_file
from gps_error_ros.sim.synthetic import synthetic_trace
from gps_error_ros.traces.trace_io import write_trace_csv
from measured import DATA


def test_one_recording_gets_the_note_and_an_allowance_for_other_days(tmp_path, capsys):
    path = write_trace_csv(synthetic_trace('none', 1, 1800), tmp_path / 'one.csv')
    out = tmp_path / 'p.yaml'
    assert cli(['calibrate', str(path), '-o', str(out), '--population']) == 0
    printed = capsys.readouterr().out
    assert f'note: {ONE_OCCASION_NOTE}. An allowance' in printed, printed
    profile = load_profile_file(out)
    pop = profile.population
    days = profile.fit['population']['between_days']
    assert profile.fit['population']['occasions'] == 1 and days['ratio'] == DAY_RATIO
    # the held part: the ratio times the blocks' bias SD (horizontal RMS), on both axes
    held = DAY_RATIO * math.sqrt((pop.bias_sd_m[0] ** 2 + pop.bias_sd_m[1] ** 2) / 2)
    assert pop.run_bias_sd_m == pytest.approx((held, held), rel=1e-3)
    assert days['held_sd_m'] == pytest.approx(held, rel=1e-3)


def test_the_allowance_can_be_left_out(tmp_path, capsys):
    path = write_trace_csv(synthetic_trace('none', 1, 1800), tmp_path / 'one.csv')
    out = tmp_path / 'p.yaml'
    assert cli(['calibrate', str(path), '-o', str(out), '--population',
                '--day-allowance', '0']) == 0
    assert 'no allowance added' in capsys.readouterr().out
    profile = load_profile_file(out)
    assert profile.population.run_bias_sd_m is None
    assert 'between_days' not in profile.fit['population']


def test_recordings_of_several_occasions_get_no_note_and_no_allowance(tmp_path, capsys):
    walks = [str(DATA / f'snapper-walk-w0{i}.csv') for i in (0, 1, 2, 3)]
    out = tmp_path / 'w.yaml'
    assert cli(['calibrate', *walks, '-o', str(out), '--population']) == 0
    printed = capsys.readouterr().out
    assert 'population (' in printed and ONE_OCCASION_NOTE not in printed, printed
    fit = load_profile_file(out).fit['population']
    assert fit['occasions'] == 4 and 'between_days' not in fit


def test_the_ratio_is_the_walks_between_their_occasions():
    """DAY_RATIO is what the walks give (tools/day_allowance.py): refit, it must agree."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / 'tools'))
    from day_allowance import day_ratio
    from gps_error_ros.traces.trace_io import read_trace_csv
    walks = [read_trace_csv(p) for p in sorted(DATA.glob('snapper-walk-*.csv'))]
    assert round(day_ratio(walks), 2) == DAY_RATIO

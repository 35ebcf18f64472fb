"""Bad command lines and inputs: refused at parse time, naming what was wrong."""

import re
from types import SimpleNamespace

import pytest

from gps_error_ros.cli import main as cli
from gps_error_ros.diagnose.findings import Findings
from gps_error_ros.sim.synthetic import synthetic_trace
from gps_error_ros.traces.trace_io import read_trace_csv, TraceError, write_trace_csv


@pytest.mark.parametrize('argv, option', [
    (['validate', 'DS5', 'x.csv', '--out', 'v', '--sims', '0'], '--sims'),
    (['validate', 'DS5', 'x.csv', '--out', 'v', '--sims', '1'], '--sims'),
    (['validate', 'DS5', 'x.csv', '--out', 'v', '--max-lag', '0'], '--max-lag'),
    (['diagnose', 'x.csv', '--sims', '0'], '--sims'),
    (['calibrate', 'x.csv', '-o', 'p.yaml', '--order', '17'], '--order'),
    (['calibrate', 'x.csv', '-o', 'p.yaml', '--max-order', '0'], '--max-order'),
    (['calibrate', 'x.csv', '-o', 'p.yaml', '--max-truth-gap', '-1'], '--max-truth-gap'),
    (['simulate', '--seed', '1', '--agents', '0', '--duration', '5', '--out', 'e.npz'],
     '--agents'),
    (['simulate', '--seed', '1', '--agents', '3', '--duration', '0', '--out', 'e.npz'],
     '--duration'),
    (['simulate', '--seed', '-2', '--agents', '3', '--duration', '5', '--out', 'e.npz'],
     '--seed'),
    (['synth', 'none', '-o', 'w.csv', '--duration', '10'], '--duration'),
])
def test_numeric_options_are_range_checked_at_parse_time(argv, option, capsys):
    with pytest.raises(SystemExit) as exc:
        cli(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f'argument {option}' in err and 'expected' in err, err


def test_mode_and_output_errors_name_the_option(tmp_path, capsys):
    assert cli(['simulate', '--seed', '1', '--agents', '3', '--out',
                str(tmp_path / 'e.npz')]) == 2
    assert 'expected --trajectories INPUT, or --agents N and --duration S' in \
        capsys.readouterr().err
    assert cli(['simulate', '--seed', '1', '--agents', '3', '--duration', '5',
                '--trajectories', 'x.csv', '--out', str(tmp_path / 'e.npz')]) == 2
    assert 'two modes' in capsys.readouterr().err
    walk = write_trace_csv(synthetic_trace('none', 1, 600), tmp_path / 'w.csv')
    assert cli(['calibrate', str(walk), '-o', str(tmp_path / 'no' / 'p.yaml')]) == 2
    assert 'does not exist' in capsys.readouterr().err
    empty = tmp_path / 'empty'
    empty.mkdir()
    assert cli(['calibrate', str(empty), '-o', str(tmp_path / 'p.yaml')]) == 2
    assert 'a folder with no trace CSV (*.csv) and no rosbag2' in capsys.readouterr().err
    # a folder of recordings is its recordings
    assert cli(['calibrate', str(tmp_path), '-o', str(tmp_path / 'p.yaml')]) == 0
    assert 'w.csv: no gross failures' in capsys.readouterr().out


def test_seed_minus_one_draws_a_seed_and_says_which(tmp_path, capsys):
    assert cli(['simulate', '--seed', '-1', '--agents', '2', '--duration', '3',
                '--out', str(tmp_path / 'e.npz')]) == 0
    assert 'no seed given: using seed' in capsys.readouterr().out


def test_simulated_multi_agent_trace_calibrates_per_agent(tmp_path, capsys):
    truth = tmp_path / 'truth.csv'
    lines = ['t,agent,truth_lat,truth_lon']
    for k in range(700):
        for name in ('alice', 'bob'):
            lines.append(f'{k},{name},40.75,-73.99')
    truth.write_text('\n'.join(lines) + '\n')
    noisy = tmp_path / 'noisy.csv'
    assert cli(['simulate', '--profile', 'DS2', '--seed', '4', '--trajectories',
                str(truth), '--out', str(noisy)]) == 0
    with pytest.raises(TraceError, match="2 agents \\('alice', 'bob'\\).*--agent"):
        read_trace_csv(noisy)
    assert cli(['calibrate', str(noisy), '-o', str(tmp_path / 'p.yaml')]) == 2
    assert '--agent NAME' in capsys.readouterr().err
    assert cli(['calibrate', str(noisy), '--agent', 'bob', '-o',
                str(tmp_path / 'bob.yaml')]) == 0
    assert "of agent 'bob'" in capsys.readouterr().out
    assert len(read_trace_csv(noisy, 'alice')) == 700
    with pytest.raises(TraceError, match="agent 'carol': 0 row"):
        read_trace_csv(noisy, 'carol')


def test_calibrate_remarks_when_the_pacf_hits_the_largest_order(tmp_path, capsys):
    walk = write_trace_csv(synthetic_trace('none', 2, 900), tmp_path / 'w.csv')
    assert cli(['calibrate', str(walk), '-o', str(tmp_path / 'p.yaml'),
                '--max-order', '1']) == 0
    out = capsys.readouterr().out
    assert 'note: the north PACF is significant up to the largest order allowed' in out
    assert cli(['calibrate', str(walk), '-o', str(tmp_path / 'p.yaml')]) == 0
    assert 'note:' not in capsys.readouterr().out


def test_diagnose_remarks_when_the_improvement_may_be_nothing(tmp_path, capsys):
    """The note follows the interval diagnose prints, whichever way this walk falls."""
    walk = write_trace_csv(synthetic_trace('receiver_latency', 1, 3600), tmp_path / 'w.csv')
    assert cli(['diagnose', str(walk), '--sims', '20']) == 0
    out = capsys.readouterr().out
    assert 'effects found: motion_lag' in out
    lo, hi = map(float, re.search(r'95 % CI (\S+) \.\. (\S+)\)', out).groups())
    assert ('interval of the improvement spans zero' in out) == (lo <= 0.0 <= hi)


@pytest.mark.parametrize('effects, kept, ci, expected', [
    ([], [], (-0.1, 0.2), None),
    (['motion_lag'], [], (0.0, 0.0), 'no effect kept'),
    (['motion_lag'], ['motion_lag'], (-0.002, 0.01), 'spans zero'),
    (['motion_lag'], ['motion_lag'], (0.0, 0.01), 'spans zero'),
    (['motion_lag'], ['motion_lag'], (0.001, 0.01), None),
])
def test_the_improvement_note_says_when_the_gain_may_be_nothing(effects, kept, ci, expected):
    # the three fields the note reads, on a stand-in for the whole findings
    note = Findings.note(SimpleNamespace(effects=effects, selection=SimpleNamespace(kept=kept),
                                         improvement=SimpleNamespace(ci95=ci)))
    assert (note is None) if expected is None else (expected in note)


def test_messages_show_plain_numbers_and_the_profiles_that_have_fits(tmp_path, capsys):
    bad = tmp_path / 'dup.csv'
    bad.write_text('t,lat,lon,truth_lat,truth_lon\n1,40,-73,40,-73\n1,40,-73,40,-73\n')
    assert cli(['calibrate', str(bad), '-o', str(tmp_path / 'p.yaml')]) == 2
    err = capsys.readouterr().err
    assert 'duplicate time t=1.0 after 1.0' in err and 'np.float64' not in err
    assert cli(['validate', 'DS9', str(bad), '--out', str(tmp_path / 'v')]) == 2
    err = capsys.readouterr().err
    assert 'expected one of DS1, DS2, DS5, DS7, phone-suburban-drive, ' \
        'snapshot-receiver-on-foot (or DS3, DS4, ' \
        'DS6, which have no published fit)' in err


def test_a_recording_slower_than_the_grid_is_refused_by_every_fitting_command(
        tmp_path, capsys):
    walk = synthetic_trace('none', 1, 900)
    keep = slice(None, None, 3)                      # a fix every 3 s
    slow = write_trace_csv(type(walk)(walk.name, walk.t[keep], walk.lat[keep],
                                      walk.lon[keep], walk.truth_lat[keep],
                                      walk.truth_lon[keep]), tmp_path / 'slow.csv')
    for argv in (['calibrate', str(slow), '-o', str(tmp_path / 'p.yaml')],
                 ['validate', 'DS5', str(slow), '--out', str(tmp_path / 'v')],
                 ['diagnose', str(slow)], ['compare', str(slow)]):
        assert cli(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.strip().splitlines() == [
            f'gps_error {argv[0]}: slow.csv: its fixes are 3 s apart (median interval): '
            f'the model steps at 1 Hz and its fits use errors on neighbouring steps, so '
            f'they need fixes at 1 Hz or faster (a median interval of at most 1.5 s)'], err
    assert not (tmp_path / 'p.yaml').exists()


def test_a_held_out_part_too_gappy_to_score_says_why(tmp_path, capsys):
    import numpy as np
    walk = synthetic_trace('ar5', 1, 1200)
    keep = np.ones(len(walk), bool)
    keep[int(len(walk) * 0.72)::3] = False           # the held-out part: pairs of fixes
    gappy = write_trace_csv(type(walk)(walk.name, walk.t[keep], walk.lat[keep],
                                       walk.lon[keep], walk.truth_lat[keep],
                                       walk.truth_lon[keep]), tmp_path / 'gappy.csv')
    assert cli(['diagnose', str(gappy), '--sims', '20']) == 2
    err = capsys.readouterr().err
    assert re.search(r'gappy.csv: only \d+ of \d+ held-out samples can be scored \(one is '
                     r'when the \d+ steps before it have fixes too.*at least 40 are needed',
                     err), err


def test_a_recording_long_enough_but_gappy_is_told_apart_from_a_short_one(tmp_path, capsys):
    walk = synthetic_trace('none', 1, 700)
    keep = (walk.t < 300) | (walk.t >= 640)
    gappy = write_trace_csv(type(walk)(walk.name, walk.t[keep], walk.lat[keep],
                                       walk.lon[keep], walk.truth_lat[keep],
                                       walk.truth_lon[keep]), tmp_path / 'gappy.csv')
    short = write_trace_csv(type(walk)(walk.name, walk.t[:250], walk.lat[:250],
                                       walk.lon[:250], walk.truth_lat[:250],
                                       walk.truth_lon[:250]), tmp_path / 'short.csv')
    assert cli(['compare', str(gappy)]) == 2
    err = capsys.readouterr().err
    assert 'need at least 180 and 80 (its 699 s would do, but its gaps, gross failures ' \
        'included, leave too few; the first 70 % of the time trains)' in err, err
    assert cli(['diagnose', str(short)]) == 2
    err = capsys.readouterr().err
    assert '(a trace of about 267 s or more; the first 70 % of the time trains)' in err, err


def test_validate_says_which_class_of_profile_it_checked(tmp_path, capsys):
    from pathlib import Path
    root = Path(__file__).resolve().parents[2]
    data = root / 'data' / 'gsdc2020-mtv1-pixel4.csv'
    for profile, says in (
            ('DS5', 'profile class: one AR process for every agent, no population'),
            ('phone-suburban-drive', 'profile class: a population with a Gaussian AR within'),
            (str(root / 'docs/close-the-loop/gsdc2020-mtv1-pixel4.extended.yaml'),
             'profile class: the extended model (')):
        assert cli(['validate', profile, str(data), '--out', str(tmp_path / 'v'),
                    '--sims', '20']) == 0
        assert says in capsys.readouterr().out, profile

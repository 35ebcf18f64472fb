"""A population from one occasion says what it cannot know: how much days differ."""

from gps_error_ros.cli import main as cli
from gps_error_ros.fit.population_fit import ONE_OCCASION_NOTE
from gps_error_ros.sim.synthetic import synthetic_trace
from gps_error_ros.model.profiles import load_profile_file
from gps_error_ros.traces.trace_io import write_trace_csv
from measured import DATA


def test_one_recording_gets_the_note_and_the_profile_counts_its_occasions(tmp_path, capsys):
    path = write_trace_csv(synthetic_trace('none', 1, 1800), tmp_path / 'one.csv')
    out = tmp_path / 'p.yaml'
    assert cli(['calibrate', str(path), '-o', str(out), '--population']) == 0
    printed = capsys.readouterr().out
    assert f'note: {ONE_OCCASION_NOTE}' in printed, printed
    raw = load_profile_file(out)
    assert raw.population is not None


def test_recordings_of_several_occasions_get_no_note(tmp_path, capsys):
    walks = [str(DATA / f'snapper-walk-w0{i}.csv') for i in (0, 1, 2)]
    assert cli(['calibrate', *walks, '-o', str(tmp_path / 'w.yaml'), '--population']) == 0
    printed = capsys.readouterr().out
    assert 'population (' in printed and ONE_OCCASION_NOTE not in printed, printed

"""The long-recording benchmark, short: it runs both commands and reports time and memory."""

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / 'bench'))
import bench_long_recording  # noqa: E402


def test_short_long_recording_bench(tmp_path, capsys):
    """Both commands, both lengths, time and memory printed; a goal missed is the exit status."""
    out = tmp_path / 'long.json'
    # a walk without jumps (the jump filter is what the real run times): seconds, not a minute
    assert bench_long_recording.main(['--hours', '0.18', '--base-hours', '0.17', '--max-s',
                                      '0.01', '--scenario', 'none', '--json', str(out)]) == 1
    said = capsys.readouterr().out
    assert 'diagnose on 0.18 h at 1 Hz' in said and 'compare on 0.18 h at 1 Hz' in said
    assert 'NOT MET' in said and 'peak RSS' in said
    doc = json.loads(out.read_text())
    assert not doc['goals_met'] and doc['diagnose_0.18h']['peak_rss_mb'] > 50
    assert doc['compare_0.17h']['seconds'] > 0


def test_diagnose_reports_each_stage_once():
    from gps_error_ros.diagnose import diagnose
    from gps_error_ros.diagnose.pipeline import STAGES
    from gps_error_ros.sim.synthetic import synthetic_trace
    calls = []
    diagnose(synthetic_trace('none', 3, 1200), sims=20, done=lambda: calls.append(1))
    assert len(calls) == STAGES

"""The document generators of tools/ regenerate from a data directory."""

import json
from pathlib import Path
import re
import subprocess
import sys

import numpy as np

from trace_helpers import synthetic_trace, write_csv

TOOLS = Path(__file__).resolve().parents[2] / 'tools'


def _tools(*names):
    """Return the named objects of tools/generalisation.py."""
    sys.path.insert(0, str(TOOLS))
    try:
        import generalisation
    finally:
        sys.path.remove(str(TOOLS))
    return [getattr(generalisation, n) for n in names]


def _row(m, lo, hi):
    """Return an envelope row: ``m`` measured, ``lo`` to ``hi`` simulated."""
    return {'measured': m, 'sim_lo': lo, 'sim_hi': hi, 'sim_median': (lo + hi) / 2,
            'percentile': 50.0}


def test_calibration_doc_regenerates_from_a_data_directory(tmp_path):
    data = tmp_path / 'data'
    data.mkdir()
    trace, _ = synthetic_trace(800, seed=8)
    write_csv(data / 'synthetic.csv', trace)
    r = subprocess.run([sys.executable, str(TOOLS / 'calibration_doc.py'),
                        '--data', str(data), '--out', str(tmp_path / 'docs')],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    doc = (tmp_path / 'docs' / 'calibration.md').read_text()
    assert '## synthetic.csv' in doc and 'Held out' in doc
    assert (tmp_path / 'docs' / 'calibration' / 'synthetic-pacf-holdout.png').exists()
    rec = json.loads((tmp_path / 'docs' / 'calibration' / 'synthetic.json').read_text())
    assert rec['holdout']['test_samples'] == 240
    assert np.isfinite(rec['ar3']['profile']['north']['sigma_w'])


def test_outage_evidence_on_the_measured_traces():
    """The availability evidence of docs/availability.md, from data/."""
    from measured import DATA as data
    r = subprocess.run([sys.executable, str(TOOLS / 'outage_evidence.py'), '--data', str(data)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert 'gsdc2020-mtv1-pixel4.csv: 1737 fixes on the grid, 0 outage(s), 2 dropped' in out
    assert 'longest 109 steps' in out            # the static phone's hold


def test_velocity_evidence_on_the_measured_phones():
    """The comparison of docs/velocity.md runs on data/ (few simulations)."""
    from measured import DATA as data
    r = subprocess.run([sys.executable, str(TOOLS / 'velocity_evidence.py'), '--data', str(data),
                        '--sims', '5'], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.count('held out') == 2 and 'course error RMS 10-100 m/s' in r.stdout
    assert r.stdout.count('the course matches best') == 4       # 2 phones, 2 speed bands
    assert r.stdout.count('across the track RMS') == 4
    # on the open road the error is heavy-tailed: the XL's along the track most of all
    # (a normal error has a median deviation of 0.67 of its RMS and a kurtosis of 3)
    shapes = re.findall(r"15-100 m/s, \d+ rows, the error's shape: along RMS [0-9.]+ m/s, median "
                        r"deviation / RMS ([0-9.]+), kurtosis ([0-9.]+); across", r.stdout)
    assert len(shapes) == 2 and float(shapes[1][0]) < 0.4 and float(shapes[1][1]) > 10, shapes
    # the floor of simulate's true velocity (1-s chords of 1-Hz truth), no error added:
    # it errs in course at highway speed more than the XL does (docs/velocity.md)
    floors = re.findall(r"chord alone, no error added: .*course error RMS 10-100 m/s ([0-9.]+)",
                        r.stdout)
    assert len(floors) == 2 and all(float(f) > 0.3 for f in floors), r.stdout
    # the open road on the rolling folds (docs/velocity.md): with the speed's own lag
    # (0.2 s) the Pixel 4's section gives its speed error within 8 mm/s on every fold
    # (with one lag for speed and course, 0.4 s, it gave 0.012-0.022 m/s too much),
    # the lag's part smaller than the table's
    folds = re.findall(r"origin [0-9.]+, \d+ rows: phone ([0-9.]+) m/s; section SD ([0-9.]+), "
                       r"its lag \([0-9.]+ s\) alone ([0-9.]+), together ([0-9.]+)", r.stdout)
    assert len(folds) == 6, r.stdout
    assert all(abs(float(t) - float(p)) <= 0.008 and float(g) < float(sd)
               for p, sd, g, t in folds[:3]), folds


def test_each_phones_profiles_are_validated_on_the_other(tmp_path):
    """tools/phone_transfer.py: the profiles a user writes, validated as a user would."""
    from gps_error_ros.cli import main as cli
    from gps_error_ros.model.profiles import load_profile_file
    from gps_error_ros.sim.synthetic import synthetic_trace as walk
    from gps_error_ros.traces.trace_io import write_trace_csv

    sys.path.insert(0, str(TOOLS))
    try:
        from phone_transfer import transfer, transfer_lines
    finally:
        sys.path.remove(str(TOOLS))
    data, close, out = (tmp_path / d for d in ('data', 'close', 'out'))
    for d in (data, close, out):
        d.mkdir()
    phones = ('a.csv', 'b.csv')
    for seed, name in enumerate(phones):
        write_trace_csv(walk('none', seed, 1300), data / name)
        assert cli(['diagnose', str(data / name), '--profile-out',
                    str(close / name.replace('.csv', '.extended.yaml'))]) == 0
    rows = transfer(data, phones, out, close, sims=40)
    # 910 s of training make 3 blocks of 300 s: a population section is fitted
    assert load_profile_file(out / 'a.population.yaml').population is not None
    assert [(r['profile'], r['validated_on']) for r in rows] == [
        ('a.extended.yaml', 'b.csv'), ('a.population.yaml', 'b.csv'),
        ('b.extended.yaml', 'a.csv'), ('b.population.yaml', 'a.csv')]
    for r in rows:
        assert all(0.0 <= r[ax][m] <= 1.0 for ax in ('north', 'east')
                   for m in ('acf', 'quantiles'))
        assert 0.0 <= r['joint_percentile'] <= 100.0
    table = [line for line in transfer_lines(rows) if line.startswith('| a.') or
             line.startswith('| b.')]
    assert len(table) == 4
    r = rows[1]
    assert table[1].split(' | ')[2:] == [
        f'{100 * r[ax][m]:.0f} %' for ax in ('north', 'east') for m in ('acf', 'quantiles')
    ] + [f'{r["joint_percentile"]:.0f} |']


def test_the_generalisation_page_shows_where_the_population_is_beaten():
    """tools/generalisation.py: the section on a fold where a class scores better."""
    from gps_error_ros.judge.beaten import pacf_against

    sys.path.insert(0, str(TOOLS))
    try:
        from generalisation import _beaten_lines
    finally:
        sys.path.remove(str(TOOLS))
    pacf = pacf_against({'north': [0.9, 0.3], 'east': [0.8, 0.02], 'bound': 0.05},
                        {'north': [0.9, 0.01], 'east': [0.8, 0.2], 'bound': 0.06})
    gain = {'mean': -0.3, 'ci95': [-0.5, -0.1]}
    beaten = {'winners': ['ar1'], 'block_samples': 150, 'far_sd': 2.0,
              'bias_sd_m': [0.6, 1.0], 'far': {'samples': 0},
              'near': {'samples': 300, 'ar1': gain}, 'pacf': pacf}
    folds = [{'fold': 'f1', 'classes': {'population': {
        'where_beaten': beaten, 'fit': {'within_order': {'north': 3, 'east': 1}}}}},
             {'fold': 'f2', 'classes': {'population': {'where_beaten': None}}}]
    lines = _beaten_lines([('phones', 'across', folds, None)])
    text = '\n'.join(lines)
    assert lines[0].startswith('## Where a simpler class scores better')
    assert '**phones, f1**: AR(1)' in text and 'f2' not in text
    assert '(0 samples): none. In the others (300 samples): AR(1) -0.300 (-0.500 to -0.100)' \
        in text
    assert '| training, north | 0.050 | **0.90** | **0.30** |' in text
    assert '| held out, east | 0.060 | **0.80** | **0.20** |' in text
    assert 'held-out part: north 2; east none.' in text
    assert _beaten_lines([('phones', 'across', folds[1:], None)]) == []
    # the reading follows the figures: a gain near the population's mean says not the bias;
    # lags only the training part has on one axis say nothing of the dynamics
    assert 'Reading: AR(1) score better beyond the interval over the blocks whose level ' \
           'lies within 2 bias SDs' in text
    assert 'lags the held-out errors lack' not in text
    beaten['pacf'] = pacf_against({'north': [0.9, 0.3], 'east': [0.8, 0.3], 'bound': 0.05},
                                  {'north': [0.9, 0.01], 'east': [0.8, 0.02], 'bound': 0.06})
    beaten['far'], beaten['near'] = {'samples': 300, 'ar1': gain}, {'samples': 0}
    text = '\n'.join(_beaten_lines([('phones', 'across', folds, None)]))
    assert 'Only over the blocks whose level lies beyond 2 bias SDs do AR(1)' in text
    assert 'within blocks: north 3, east 1) predicts dynamics the held-out receiver' in text
    assert 'choose more lags' not in text and 'The AR order within blocks' not in text
    # the orders each part's own blocks choose, and what they say of the lags
    order = {'order': 3, 'gain_per_sample': 0.3}
    beaten['orders'] = {'train': {'blocks': 6, 'north': order, 'east': order},
                        'held_out': {'blocks': 5, 'north': {'order': 1, 'gain_per_sample': 0.0},
                                     'east': {'order': 2, 'gain_per_sample': 0.002}}}
    text = '\n'.join(_beaten_lines([('phones', 'across', folds, None)]))
    assert ('training part (6 blocks): north 3, east 3 (0.30 / 0.30 nats per sample below '
            'AR(1)); held-out part (5 blocks): north 1, east 2 (0.00 / 0.00 nats') in text
    assert "The training part's blocks, each predicted from the others, choose more lags" \
        in text
    beaten['orders']['train']['east'] = {'order': 3, 'gain_per_sample': 0.004}   # noise
    text = '\n'.join(_beaten_lines([('phones', 'across', folds, None)]))
    assert 'choose more lags' not in text
    beaten['orders'] = {'train': {'blocks': 4, 'north': {'order': 1, 'gain_per_sample': 0.0},
                                  'east': {'order': 1, 'gain_per_sample': 0.0}},
                        'held_out': None}
    text = '\n'.join(_beaten_lines([('phones', 'across', folds, None)]))
    assert 'held-out part: fewer than 3 blocks' in text
    assert ("order within blocks is more than the training part's own blocks choose (north 3 "
            'against 1). The lags beyond') in text


def test_the_generalisation_page_shows_the_training_blocks_persistence():
    """tools/generalisation.py: the blocks' lag-1 ACF spread, out where above its range."""
    from gps_error_ros.judge.window_persistence import spread_above

    _spread_rows, = _tools('_spread_rows')

    spread = {'windows': 4, 'acf1_sd_north': _row(0.31, 0.02, 0.12),
              'acf1_sd_east': _row(0.05, 0.02, 0.12), 'lowest_acf1_north': _row(0.2, 0.5, 0.9),
              'lowest_acf1_east': _row(0.6, 0.5, 0.9)}
    folds = [{'fold': 'f1', 'classes': {'population': {'persistence_spread': spread}}},
             {'fold': 'f2', 'classes': {'population': {'persistence_spread': None}}}]
    lines = _spread_rows(folds)
    assert lines[-1] == ('| f1 | 4 | 0.31 (0.02 to 0.12) **out** | 0.05 (0.02 to 0.12) | '
                         '0.20 (0.50 to 0.90) **out** | 0.60 (0.50 to 0.90) |')
    assert not any('f2' in line for line in lines)
    above, judged = spread_above(folds)
    assert (len(above), judged) == (1, 2) and above[0][:2] == ('f1', 'north')
    assert _spread_rows(folds[1:]) == [] and spread_above(folds[1:]) == ([], 0)


def test_the_generalisation_page_tells_speed_and_course_misses_without_precedent():
    """tools/generalisation.py: the training stretches' range beside each velocity measure."""
    _velocity_precedent, _velocity_rows = _tools('_velocity_precedent', '_velocity_rows')

    section = {'sigma': 0.3, 'phi': 0.2, 'lag_s': 0.5, 'standstill': 0.0}
    group = {'section': section, 'inside_95': 1 / 3,
             'measures': {'speed_sd 5-15 m/s': _row(0.9, 0.4, 0.5),       # out, new
                          'course_p50 15+ m/s': _row(0.05, 0.1, 0.2),     # out, seen
                          'speed_mean 5-15 m/s': _row(0.0, -0.1, 0.1),    # inside
                          'speed_sd 15+ m/s': _row(0.3, 0.1, 0.2)},       # out, unmeasured
             'train_windows': {'span_s': 200.0, 'windows': 3,
                               'range': {'speed_sd 5-15 m/s': [0.35, 0.55],
                                         'course_p50 15+ m/s': [0.04, 0.2],
                                         'speed_mean 5-15 m/s': [-0.2, 0.1]}}}
    folds = [{'fold': 'f1', 'velocity': group}, {'fold': 'f2', 'velocity': None}]
    text = '\n'.join(_velocity_rows(folds))
    assert '| speed_sd 5-15 m/s | 0.900 **out** | 0.400 to 0.500 | 0.350 to 0.550 **new** |' \
        in text
    assert '| course_p50 15+ m/s | 0.050 **out** | 0.100 to 0.200 | 0.040 to 0.200 |' in text
    assert '| speed_sd 15+ m/s | 0.300 **out** | 0.100 to 0.200 | - |' in text
    assert _velocity_precedent(folds) == (
        'Of the 3 speed and course measures outside their ranges, 1 lie outside every stretch '
        'of the training rows as long as the held-out rows (1 in a band no such stretch had '
        'rows enough in) (the speed and course table). ')
    assert _velocity_precedent(folds[1:]) == '' and _velocity_rows(folds[1:]) == []


def test_the_generalisation_page_judges_every_recording_it_is_given(tmp_path):
    """tools/generalisation.py: each trace but the walks alone; one too short or unread, named."""
    alone, set_order = _tools('alone', 'set_order')
    for name, n in (('long.csv', 900), ('short.csv', 300)):
        write_csv(tmp_path / name, synthetic_trace(n, seed=3)[0])
    write_csv(tmp_path / 'snapper-walk-w99.csv', synthetic_trace(900, seed=4)[0])
    (tmp_path / 'broken.csv').write_text('t,lat\n1,2\n')
    judged, not_judged = alone(tmp_path)
    assert [name for name, _ in judged] == ['long.csv']              # the walk is its own set
    assert not_judged['short.csv'] == '300 samples: a rolling fold would hold out 37'
    assert not_judged['broken.csv'].startswith('not read: ')
    assert set(not_judged) == {'short.csv', 'broken.csv'}
    assert set_order(judged)[0] == 'long.csv'


def test_the_generalisation_page_regenerates_from_a_data_directory(tmp_path):
    """tools/generalisation.py end to end on recordings of its own: no walks, no GSDC phones."""
    data = tmp_path / 'data'
    data.mkdir()
    write_csv(data / 'long.csv', synthetic_trace(1200, seed=3)[0])
    write_csv(data / 'short.csv', synthetic_trace(300, seed=3)[0])
    r = subprocess.run([sys.executable, str(TOOLS / 'generalisation.py'), '--data', str(data),
                        '--out', str(tmp_path), '--sims', '10', '--smoother', '0'],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    page = (tmp_path / 'docs' / 'generalisation.md').read_text()
    assert '## long.csv: rolling origin (3 folds)' in page
    assert 'Not judged: short.csv (300 samples: a rolling fold would hold out 37).' in page
    assert '## SnapperGPS walks' not in page and '## GSDC phones of one drive' not in page
    assert json.loads((tmp_path / 'docs' / 'generalisation' / 'long.json').read_text())['set'] \
        == 'long.csv'

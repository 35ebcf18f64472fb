"""Speed and course on held-out rows: the velocity section judged by band of the true speed."""

import numpy as np

from gps_error_ros.judge.generalise import rolling_splits
from gps_error_ros.fit.holdout import like_windows
from gps_error_ros.judge.velocity_check import (band_measures, precedent, velocity_group,
                                                velocity_line)
from gps_error_ros.fit.gross_failures import without_rows
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.model.velocity import velocity_from_dict
from gps_error_ros.sim.simulate import simulate_csv
from gps_error_ros.traces.trace_io import read_trace_csv
from trace_helpers import write_drive

TRUE = {'sigma': 0.15, 'phi': 0.7, 'lag_s': 0.7, 'standstill': 0.0}


def _phone(tmp_path, name, sigma, seed):
    """Return a simulated phone's drive whose velocity error has SD ``sigma`` per component."""
    if not (tmp_path / 'truth.csv').exists():
        write_drive(tmp_path / 'truth.csv', steps=2400)
    simulate_csv(tmp_path / 'truth.csv', tmp_path / name, load_profile('DS1').model(), 1.0,
                 seed, velocity_from_dict(dict(TRUE, sigma=sigma)))
    return read_trace_csv(tmp_path / name)


def test_the_bands_split_the_rows_by_true_speed():
    truth = np.r_[np.full(40, 2.0), np.full(40, 8.0), np.full(10, 20.0)]
    speed = truth + np.r_[np.full(40, 0.1), np.full(40, -0.2), np.zeros(10)]
    got = band_measures(speed, np.full(90, 10.0), truth, np.full(90, 9.0))
    assert abs(got['speed_mean 1-5 m/s'] - 0.1) < 1e-12 and got['speed_sd 1-5 m/s'] < 1e-12
    assert abs(got['speed_mean 5-15 m/s'] + 0.2) < 1e-12
    assert got['course_p50 5-15 m/s'] == 1.0
    assert not any('15+' in k for k in got)              # 10 rows: too few to judge


def test_a_section_holds_on_its_own_phone_and_not_on_a_noisier_one(tmp_path):
    own = _phone(tmp_path, 'own.csv', 0.15, 5)
    noisy = _phone(tmp_path, 'noisy.csv', 0.6, 6)
    train = without_rows(own, own.t >= 1600)
    for test, holds in ((without_rows(own, own.t < 1600), True),
                        (without_rows(noisy, noisy.t < 1600), False)):
        g = velocity_group(train, test, sims=60, seed=1)
        assert abs(g['section']['sigma'] - 0.15) < 0.03
        names = set(g['measures'])
        assert {'speed_sd 1-5 m/s', 'speed_sd 5-15 m/s', 'course_p50 5-15 m/s'} <= names
        sd_inside = [g['measures'][k]['sim_lo'] <= g['measures'][k]['measured']
                     <= g['measures'][k]['sim_hi'] for k in names if k.startswith('speed_sd')]
        assert all(sd_inside) if holds else not any(sd_inside), g['measures']
        # the training rows' stretches as long as the held-out rows: 1599 s of training
        # rows against 800 s held out, windows stepped by 400 s
        w = g['train_windows']
        assert w['windows'] == 3 and set(w['range']) <= names
        miss, new, unmeasured = precedent(g)
        if holds:
            assert g['inside_95'] >= 0.6
            assert not set(new) & {'speed_sd 1-5 m/s', 'speed_sd 5-15 m/s'}
        else:                   # four times the training noise: nothing that trained was like it
            assert {'speed_sd 1-5 m/s', 'speed_sd 5-15 m/s'} <= set(new), (w, g['measures'])
        assert set(new) <= set(miss) and not set(new) & set(unmeasured)


def test_windows_like_a_held_out_part_stay_within_a_run():
    t = np.r_[np.arange(0.0, 1000.0), np.arange(1100.0, 1250.0), np.arange(1400.0, 1402.0)]
    masks = like_windows(t, 400.0)
    starts = [t[m][0] for m in masks]
    # windows of 400 s stepped by 200 s that end within the first run (999 s), the 150-s run
    # whole, the 2-s one not
    assert starts == [0.0, 200.0, 400.0, 1100.0]
    assert [int(m.sum()) for m in masks] == [400, 400, 400, 150]
    assert like_windows(np.array([]), 10.0) == []


def test_folds_of_a_trace_with_speed_columns_carry_the_group(tmp_path):
    own = _phone(tmp_path, 'own.csv', 0.15, 5)
    (label, split), *_ = rolling_splits(own)
    assert split.velocity is not None
    train, test = split.velocity
    assert train.t.max() < test.t.min()
    fold = {'fold': label, 'velocity': velocity_group(*split.velocity, sims=40)}
    assert 'speed and course' in velocity_line([fold])
    assert velocity_line([{'fold': label, 'velocity': None}]) is None
    own.extra.pop('bearing')                  # a walk's trace: no course column
    assert rolling_splits(own)[0][1].velocity is None


def test_compare_folds_prints_and_writes_the_group(tmp_path, capsys):
    import json
    from gps_error_ros.cli import main as cli
    _phone(tmp_path, 'own.csv', 0.15, 5)
    out = tmp_path / 'folds.json'
    assert cli(['compare', str(tmp_path / 'own.csv'), '--folds', 'rolling', '--sims', '20',
                '--json', str(out)]) == 0
    assert 'speed and course (the velocity section' in capsys.readouterr().out
    folds = json.loads(out.read_text())['folds']
    assert len(folds) == 3 and all(f['velocity']['measures'] for f in folds)


def test_the_line_names_the_misses_that_no_training_stretch_was_like():
    def row(m):
        return {'measured': m, 'sim_lo': 0.1, 'sim_hi': 0.2, 'sim_median': 0.15,
                'percentile': 50.0}

    group = {'inside_95': 0.0, 'measures': {'speed_sd 5-15 m/s': row(0.9),
                                            'course_p50 15+ m/s': row(0.05)},
             'train_windows': {'windows': 2, 'range': {'speed_sd 5-15 m/s': [0.1, 0.3],
                                                       'course_p50 15+ m/s': [0.04, 0.2]}}}
    line = velocity_line([{'fold': 'f', 'velocity': group}])
    assert 'outside on some fold: course_p50 15+ m/s, speed_sd 5-15 m/s;' in line
    assert line.endswith('like the held-out rows): speed_sd 5-15 m/s')

"""``gps_error compare --test`` and ``--folds``: the classes judged across recordings."""

import json
import math

import pytest

from gps_error_ros.cli import main as cli
from gps_error_ros.fit.envelope import Envelope
from gps_error_ros.fit.population_evidence import PopulationEvidence
from gps_error_ros.judge.fold_summary import precedent
from gps_error_ros.judge.generalise import GROUPS
from gps_error_ros.judge.results import (ClassJudgement, ClassSummary, Fold, group_of,
                                         measure_key, name_of, OwnVerdict, TrainingWindows)
from gps_error_ros.fit.calibration import errors_on_grid
from gps_error_ros.sim.synthetic import synthetic_trace
from gps_error_ros.traces.trace_io import read_trace_csv, write_trace_csv

CLASSES = {'white_bias', 'ar1', 'arma11', 'ar3_paper', 'ar_p', 'extended', 'population_ar',
           'population'}


def test_train_on_recordings_and_hold_out_another(tmp_path, capsys):
    paths = [write_trace_csv(synthetic_trace('none', seed, 900), tmp_path / f'r{seed}.csv')
             for seed in (1, 2, 3)]
    out = tmp_path / 'folds.json'
    assert cli(['compare', str(paths[0]), str(paths[1]), '--test', str(paths[2]),
                '--sims', '20', '--json', str(out)]) == 0
    printed = capsys.readouterr().out
    assert 'population' in printed and 'persistence' in printed
    assert "worst group against the class's own traces" in printed
    doc = json.loads(out.read_text())
    (fold,) = doc['folds']
    n = [errors_on_grid(read_trace_csv(p)).n for p in paths]
    assert fold['test_samples'] == n[2] and fold['train_samples'] == n[0] + n[1]
    assert set(fold['classes']) == CLASSES
    # the synthetic walks have outages: every class is judged on them too
    for name, c in fold['classes'].items():
        assert math.isfinite(c['heldout_nll_per_sample']), name
        assert set(c['groups']) == set(GROUPS) | {'outages'}
        assert all(0.0 <= v <= 1.0 for v in c['groups'].values())
    ext, ar1 = (fold['classes'][k]['measures']['outages:outages'] for k in ('extended', 'ar1'))
    assert ext['sim_hi'] > 0 and ar1['sim_hi'] == 0        # availability, and a fix every step
    # 1800 training samples make 6 blocks of 300 s: a population is fitted
    assert fold['classes']['population']['fit']['fitted'] is True
    assert set(doc['summary']['population']['worst_group']) == {'group', 'inside_95'}
    own = doc['summary']['population']['own']
    assert 0.0 <= own['percentile'] <= 100.0 and 'outages' in own['groups']
    assert len(fold['classes']['ar1']['own_groups']['bias']) == 20
    # every class's score against the population's, paired on the same samples
    pop = fold['classes']['population']
    assert pop['nll_minus_population'] == {'mean': 0.0, 'ci95': [0.0, 0.0]}
    for name, c in fold['classes'].items():
        d = c['nll_minus_population']
        assert d['mean'] == pytest.approx(
            c['heldout_nll_per_sample'] - pop['heldout_nll_per_sample'], abs=1e-12), name
        assert d['ci95'][0] <= d['mean'] <= d['ci95'][1], name
        s = doc['summary'][name]['nll_minus_population']
        assert s['mean'] == pytest.approx(d['mean'], abs=1e-12)
        assert (s['lower_folds'], s['higher_folds']) == (int(d['ci95'][1] < 0),
                                                         int(d['ci95'][0] > 0)), name
    assert '- pop.' in printed
    # where a class scores better than the population beyond noise, the fold says where
    winners = [k for k, c in fold['classes'].items() if c['nll_minus_population']['ci95'][1] < 0]
    if winners:
        assert pop['where_beaten']['winners'] == winners
    else:
        assert pop['where_beaten'] is None
    # the training part's blocks, judged for their spread of persistence, and the line printed
    assert pop['persistence_spread']['windows'] == pop['fit']['blocks']
    assert 'persistence from block to block' in printed and 'fold axes' in printed
    # the two training recordings are shorter than the held-out one: each counts whole
    windows = fold['train_windows']
    assert windows['windows'] == 2 and abs(windows['span_s'] - 899.0) < 1.0
    lo, hi = windows['range']['scale:sd_north']
    assert 0.0 < lo <= hi
    # the population's error measures outside their ranges are counted in a line, or none
    missed = any(precedent(f)[0] for f in doc['folds'])
    assert ('error measures outside their ranges (population)' in printed) == missed
    _holds_the_declared_keys(doc)


def _declared(record):
    return record.__required_keys__, record.__required_keys__ | record.__optional_keys__


def _keys_ok(found, record, what):
    required, allowed = _declared(record)
    assert required <= set(found) <= allowed, (what, set(found) ^ allowed)


def _holds_the_declared_keys(doc):
    # the JSON's records are the TypedDicts of judge/results.py: no key undeclared or missing
    for fold in doc['folds']:
        _keys_ok(fold, Fold, 'fold')
        _keys_ok(fold['train_windows'], TrainingWindows, 'train_windows')
        for name, c in fold['classes'].items():
            _keys_ok(c, ClassJudgement, name)
            for measure, row in c['measures'].items():
                _keys_ok(row, Envelope, measure)
                assert measure_key(group_of(measure), name_of(measure)) == measure
            if 'fit' in c:
                _keys_ok(c['fit'], PopulationEvidence, f'{name} fit')
    for name, c in doc['summary'].items():
        _keys_ok(c, ClassSummary, name)
        if 'own' in c:
            _keys_ok(c['own'], OwnVerdict, f'{name} own')


def test_leaving_recordings_out_needs_two(tmp_path):
    path = write_trace_csv(synthetic_trace('none', 1, 600), tmp_path / 'one.csv')
    with pytest.raises(SystemExit) as exc:
        cli(['compare', str(path), '--folds', 'recordings'])
    assert 'at least 2 recordings' in str(exc.value)


def test_without_blocks_to_pool_a_population_class_is_the_class_it_wraps(tmp_path):
    train, test = (write_trace_csv(synthetic_trace('none', seed, 500), tmp_path / f'r{seed}.csv')
                   for seed in (4, 5))
    out = tmp_path / 'folds.json'
    assert cli(['compare', str(train), '--test', str(test), '--sims', '20',
                '--json', str(out)]) == 0
    doc = json.loads(out.read_text())
    (fold,) = doc['folds']
    for pop, wrapped in (('population', 'extended'), ('population_ar', 'ar_p')):
        c, w = fold['classes'][pop], fold['classes'][wrapped]
        assert c['fit']['fitted'] is False and c['same_as'] == wrapped   # 2 blocks of 300 s
        assert c['heldout_nll_per_sample'] == w['heldout_nll_per_sample']
        if pop == 'population':     # the score's reference: what it wraps ties it exactly
            assert w['nll_minus_population'] == {'mean': 0.0, 'ci95': [0.0, 0.0]}
        # the same traces; population_ar simulates the training part's outages, as
        # calibrate --population's profile carries them, and ar_p a fix at every step
        same = [g for g in c['groups'] if pop == 'population' or g != 'outages']
        assert [c['groups'][g] for g in same] == [w['groups'][g] for g in same]
        assert [c['own_groups'][g] for g in same] == [w['own_groups'][g] for g in same]
        # a tie is the best score for both, or for neither
        s = doc['summary']
        assert s[pop]['best_score_folds'] == s[wrapped]['best_score_folds']
    assert sum(s[c]['best_score_folds'] for c in s) >= 1


def test_a_fold_where_a_class_beats_the_population_says_where():
    from gps_error_ros.judge.beaten import beaten_lines
    from gps_error_ros.judge.beaten import pacf_against

    pacf = pacf_against({'north': [0.9, 0.3, 0.01], 'east': [0.8, 0.02, 0.2], 'bound': 0.05},
                        {'north': [0.9, 0.01, 0.01], 'east': [0.8, 0.02, 0.01], 'bound': 0.05})
    assert pacf['only_in_training'] == {'north': [2], 'east': [3]}
    assert pacf_against(None, pacf['train'])['only_in_training'] is None
    gain = {'mean': -0.3, 'ci95': [-0.5, -0.1]}
    fold = {'fold': 'test b.csv', 'classes': {'population': {'where_beaten': {
        'winners': ['ar1'], 'block_samples': 150, 'far_sd': 2.0,
        'far': {'samples': 300, 'ar1': gain}, 'near': {'samples': 0}, 'pacf': pacf}}}}
    lines = beaten_lines([fold, {'fold': 'x', 'classes': {'population': {'where_beaten': None}}}])
    assert len(lines) == 2
    assert lines[0].startswith('  test b.csv: ar1 below the population class')
    assert ('(300 samples): ar1 -0.300 (-0.500 to -0.100); over the others (0 samples): -'
            in lines[0])
    assert lines[1].endswith('lags: north 2; east 3')
    order = {'order': 4, 'gain_per_sample': 0.2}
    fold['classes']['population']['where_beaten']['orders'] = {
        'train': {'blocks': 6, 'north': order, 'east': order}, 'held_out': None}
    lines = beaten_lines([fold])
    assert lines[2] == ('    AR order that predicts each 300-s block best from the part\'s '
                        'others: training part north 4, east 4 (6 blocks); held out fewer '
                        'than 3 blocks')

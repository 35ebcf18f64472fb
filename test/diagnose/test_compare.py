"""``gps_error compare``: every class as a simulator, in calibrated statistics."""

import json

import numpy as np
import pytest

from bag_helpers import write_walk_bag
from gps_error_ros.cli import main as cli
from gps_error_ros.fit.fidelity import calibrated_fidelity, part_steps
from gps_error_ros.fit.holdout import Part
from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.sim.synthetic import synthetic_trace
from gps_error_ros.traces.trace_io import write_trace_csv

MODEL = ARErrorModel(AxisParams(0.5, (0.9,), 1.0), AxisParams(-0.2, (0.6,), 0.8))
CLASSES = ['white_bias', 'ar1', 'arma11', 'ar3_paper', 'ar_p', 'extended']
FIELDS = {'measured', 'sim_median', 'sim_lo', 'sim_hi', 'percentile'}


def as_part(x, cuts):
    """Return the series ``x`` (n, 2) as a Part split at ``cuts``, 50-step gaps between."""
    segs = np.split(x, cuts)
    t, start = [], 0
    for s in segs:
        t.append(start + np.arange(len(s), dtype=float))
        start += len(s) + 50
    return Part(segs, [np.zeros_like(s) for s in segs], t)


def test_a_draw_of_the_model_is_inside_and_another_model_is_not():
    keys = streams.agent_keys(3, [f's{i}' for i in range(101)])
    x = MODEL.simulate(keys, 600)                               # (600, 101, 2)
    sims = [[x[:300, i], x[300:, i]] for i in range(1, 101)]
    own = calibrated_fidelity(as_part(x[:, 0], [300]), sims)
    assert own['inside_95'] > 0.8 and own['sims'] == 100
    # white noise with a bias: the SDs, quantiles and short lags fail (at long
    # lags both autocorrelations are near zero, and a 600-sample ACF spreads
    # widely there, so those lags stay inside: inside_95 counts every measure)
    other = ARErrorModel(AxisParams(1.0, (0.01,), 4.0), AxisParams(1.0, (0.01,), 4.0))
    y = other.simulate(streams.agent_key(9), 600)[:, 0]
    bad = calibrated_fidelity(as_part(y, [300]), sims)
    assert bad['inside_95'] < own['inside_95'] - 0.15, (bad['inside_95'], own['inside_95'])
    informative = ['sd_north', 'sd_east'] + \
        [f'acf_{a}_lag0{k}' for a in ('north', 'east') for k in (1, 2)]
    for k in informative:
        v = bad['measures'][k]
        assert not v['sim_lo'] <= v['measured'] <= v['sim_hi'], (k, v)
    m = own['measures']
    assert len([k for k in m if k.startswith('acf_')]) == 60
    assert {'ne_correlation', 'sd_north', 'sd_east', 'horizontal_q50',
            'horizontal_q68', 'horizontal_q95', 'horizontal_q99'} <= set(m)
    for v in m.values():
        assert set(v) == FIELDS and v['sim_lo'] <= v['sim_median'] <= v['sim_hi']
        assert 0.0 <= v['percentile'] <= 100.0


def test_percentile_counts_ties_half():
    part = as_part(np.ones((10, 2)) * [1.0, 2.0], [5])
    part.err[0][0] = [0.0, 0.0]                  # not constant, so ACF is defined
    same = [[e.copy() for e in part.err] for _ in range(4)]
    out = calibrated_fidelity(part, same)
    assert out['measures']['sd_north']['percentile'] == 50.0
    assert out['inside_95'] == 1.0


def test_simulations_keep_the_gaps():
    part = as_part(np.zeros((20, 2)), [8, 15])
    steps = part_steps(part)
    assert [s[0] for s in steps] == [0, 58, 115] and [len(s) for s in steps] == [8, 7, 5]


@pytest.mark.parametrize('kind', ['csv', 'bag'])
def test_compare_writes_the_documented_json_and_a_figure(tmp_path, kind):
    if kind == 'csv':
        src = write_trace_csv(synthetic_trace('street_ellipse', 2, 1800), tmp_path / 'w.csv')
        extra = []
    else:
        datum = (40.0, -74.0, 0.0)
        err = MODEL.simulate(streams.agent_key(4), 1500)[:, 0]
        src = tmp_path / 'walk'
        write_walk_bag(src, 'mcap', datum, err, 50.0 + np.arange(1500.0))
        extra = ['--truth-topic', '/truth', '--datum', '40.0,-74.0,0.0']
    out = tmp_path / 'c.json'
    assert cli(['compare', str(src), *extra, '--json', str(out), '--report',
                str(tmp_path / 'r'), '--sims', '20']) == 0
    doc = json.loads(out.read_text())
    assert set(doc) == {'input', 'train_samples', 'test_samples', 'classes', 'gross_failures'}
    assert list(doc['gross_failures'].values())[0]['count'] == 0
    assert list(doc['classes']) == CLASSES
    for c in doc['classes'].values():
        assert np.isfinite(c['heldout_nll_per_sample'])
        assert 0.0 <= c['fidelity']['inside_95'] <= 1.0
        assert all(set(v) == FIELDS for v in c['fidelity']['measures'].values())
    nll = {k: c['heldout_nll_per_sample'] for k, c in doc['classes'].items()}
    assert nll['white_bias'] > nll['ar_p']
    # each class against the lowest, paired: white noise is far worse than an AR process
    lowest = min(nll, key=nll.get)
    for k, c in doc['classes'].items():
        d = c['nll_minus_best']
        assert d['mean'] == pytest.approx(nll[k] - nll[lowest], abs=1e-12)
        assert d['ci95'][0] <= d['mean'] <= d['ci95'][1]
    assert doc['classes'][lowest]['nll_minus_best'] == {'mean': 0.0, 'ci95': [0.0, 0.0]}
    assert doc['classes']['white_bias']['nll_minus_best']['ci95'][0] > 0.0
    # the same measures for every class; the bag has no gaps: no outage measures
    names = {tuple(c['fidelity']['measures']) for c in doc['classes'].values()}
    assert len(names) == 1
    assert ('outages' in names.pop()) == (kind == 'csv')     # the walk has outages
    assert (tmp_path / 'r' / 'compare.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_outages_are_measured_beside_every_class(tmp_path):
    """
    Compare outages beside every class in a trace that has them.

    The extended class simulates them (fitted on the training gaps), the
    others simulate none, and inside_95 counts them.
    """
    from trace_helpers import synthetic_trace as ar_trace

    rng = np.random.default_rng(11)
    n, drop, k = 2400, [], 30
    while k < n - 40:                           # an outage every ~120 s, 2-20 steps long
        length = int(rng.integers(2, 21))
        drop.extend(range(k, k + length))
        k += length + int(rng.geometric(1 / 100))
    trace, _ = ar_trace(n, seed=5, drop=drop)
    src = write_trace_csv(trace, tmp_path / 'gappy.csv')
    out = tmp_path / 'c.json'
    assert cli(['compare', str(src), '--json', str(out), '--report', str(tmp_path / 'r'),
                '--sims', '40']) == 0
    classes = json.loads(out.read_text())['classes']
    for name, c in classes.items():
        m = c['fidelity']['measures']
        assert set(m['outages']) == FIELDS and set(m['steps_in_outages']) == FIELDS
        assert m['outages']['measured'] >= 3, m['outages']
        inside = [v['sim_lo'] <= v['measured'] <= v['sim_hi'] for v in m.values()]
        assert c['fidelity']['inside_95'] == pytest.approx(np.mean(inside))
        if name == 'extended':
            # the same process as the data: the measured values are ordinary
            # draws (not beyond every simulation, as for the other classes)
            assert m['outages']['sim_median'] >= 3
            for key in ('outages', 'steps_in_outages'):
                assert 0.0 < m[key]['percentile'] < 100.0, m[key]
                assert 0.5 < m[key]['measured'] / m[key]['sim_median'] < 2.5, m[key]
        else:
            assert m['outages']['sim_hi'] == 0 and m['steps_in_outages']['sim_hi'] == 0
            assert m['outages']['percentile'] == 100.0
    assert (tmp_path / 'r' / 'compare.png').exists()

"""Calibrate recovers a known outage process from the gaps of a simulated trace."""

import numpy as np

from gps_error_ros.cli import main as cli
from gps_error_ros.model.availability import availability_from_dict, WithAvailability
from gps_error_ros.model.profiles import load_profile, load_profile_file
from gps_error_ros.sim.simulate import simulate_csv

TRUE = {'outage_rate': 0.02, 'durations': [[2, 0.5], [5, 0.3], [20, 0.2]]}


def test_round_trip_recovers_rate_and_durations(tmp_path):
    steps = 20000
    model = WithAvailability(load_profile('DS1').model(), availability_from_dict(TRUE))
    src = tmp_path / 'truth.csv'
    src.write_text('t,truth_lat,truth_lon\n' + ''.join(
        f'{t},40.75,-73.99\n' for t in range(steps)))
    res = simulate_csv(src, tmp_path / 'noisy.csv', model, 1.0, 9)
    assert res['positions_without_fix'] > 0
    assert cli(['calibrate', str(tmp_path / 'noisy.csv'), '-o', str(tmp_path / 'p.yaml'),
                '--order', '3']) == 0
    fitted = load_profile_file(tmp_path / 'p.yaml')
    av = fitted.availability
    k = fitted.fit['availability']['outages']
    # rate: k outages in ~n chances; its standard error is about sqrt(k) / n
    n = fitted.fit['availability']['steps_with_fix']
    assert abs(av.outage_rate - TRUE['outage_rate']) < 4 * np.sqrt(k) / n, (av, k, n)
    assert av.lengths == (2, 5, 20)
    for p, (_, want) in zip(av.probs, TRUE['durations']):
        assert abs(p - want) < 4 * np.sqrt(want * (1 - want) / k), (av.probs, k)


def test_no_outage_gives_no_section_and_a_bound(tmp_path):
    src = tmp_path / 'truth.csv'
    src.write_text('t,truth_lat,truth_lon\n' + ''.join(
        f'{t},40.75,-73.99\n' for t in range(3000) if t not in (700, 1500)))   # 2 drops
    simulate_csv(src, tmp_path / 'noisy.csv', load_profile('DS1').model(), 1.0, 9)
    assert cli(['calibrate', str(tmp_path / 'noisy.csv'), '-o', str(tmp_path / 'p.yaml'),
                '--order', '3']) == 0
    fitted = load_profile_file(tmp_path / 'p.yaml')
    assert fitted.availability is None
    ev = fitted.fit['availability']
    assert ev['outages'] == 0 and ev['dropped_steps'] == 2
    assert abs(ev['outage_rate_upper_95'] - 3 / 2997) < 1e-6


def test_validate_sets_measured_outages_beside_the_simulated(tmp_path):
    from gps_error_ros.fit.validation import validate
    from gps_error_ros.traces.trace_io import read_trace_csv
    base = load_profile('DS1').model()
    model = WithAvailability(base, availability_from_dict(TRUE))
    src = tmp_path / 'truth.csv'
    src.write_text('t,truth_lat,truth_lon\n' + ''.join(
        f'{t},40.75,-73.99\n' for t in range(3000)))
    simulate_csv(src, tmp_path / 'noisy.csv', model, 1.0, 21)
    trace = read_trace_csv(tmp_path / 'noisy.csv')
    same = validate(model, trace, sims=60, max_lag=10).to_dict()['availability']
    assert same['outages']['measured'] > 10
    for d in same.values():          # a draw of the model lies inside its own spread
        assert d['sim_lo'] <= d['measured'] <= d['sim_hi'], same
    plain = validate(base, trace, sims=20, max_lag=10).to_dict()['availability']
    assert plain['outages']['sim_hi'] == 0 and plain['outages']['percentile'] == 100.0

"""Cross-validation: the true model sits in its envelopes, a wrong one does not."""

import json
import subprocess
import sys

import pytest

from gps_error_ros.model.ar_model import ARErrorModel, AxisParams
from gps_error_ros.fit.validation import slice_trace, validate
from trace_helpers import synthetic_trace, write_csv

TRUE = ARErrorModel(AxisParams(0.3, (1.1, -0.25, 0.05), 0.6), AxisParams(-0.1, (0.8,), 0.9))
WRONG = ARErrorModel(AxisParams(0.0, (0.2,), 3.0), AxisParams(0.0, (0.2,), 3.0))


def test_true_model_fits_its_envelopes_better_than_a_wrong_one():
    trace, _ = synthetic_trace(1500, seed=31)
    result = validate(TRUE, trace, sims=200)
    good = result.to_dict()
    bad = validate(WRONG, trace, sims=200).to_dict()
    # summary() is the terminal's text of the same figures, a line per check
    text = result.summary().splitlines()
    assert text[0].startswith('  north: autocorrelation inside the envelope at '
                              f'{100 * good["north"]["acf_lags_inside_envelope"]:.0f} %')
    assert text[2].startswith('  the four shares together: percentile '
                              f'{good["shares_joint_percentile"]:.0f} ')
    assert len(text) == 3 + len(good['availability'])
    for ax in ('north', 'east'):
        # Past ~20 lags both autocorrelations are near 0 and inside either
        # envelope; the short lags tell the models apart.
        assert good[ax]['acf_lags_inside_envelope'] > \
            bad[ax]['acf_lags_inside_envelope'] + 0.3
        assert good[ax]['acf_offset_rms_lags_1_10'] < \
            0.5 * bad[ax]['acf_offset_rms_lags_1_10']
        assert good[ax]['quantiles_inside_envelope'] > \
            bad[ax]['quantiles_inside_envelope']


def test_gaps_are_kept_in_the_simulated_grid():
    trace, _ = synthetic_trace(400, drop=range(100, 150))
    res = validate(TRUE, trace, sims=20)
    assert res.segments == 2 and res.samples == 350
    assert res.grid_steps[100] == 150


def test_slice_trace():
    trace, _ = synthetic_trace(101)
    a, b = slice_trace(trace, 0, 0.7), slice_trace(trace, 0.7, 1)
    assert len(a) + len(b) == 101 and a.t[0] == 0 and b.t[0] == 0


def test_cli_writes_png_and_json(tmp_path):
    trace, _ = synthetic_trace(700, seed=2)
    csv = tmp_path / 'w.csv'
    write_csv(csv, trace)
    r = subprocess.run([sys.executable, '-m', 'gps_error_ros.cli', 'validate', 'DS1',
                        str(csv), '--out', str(tmp_path / 'v'), '--sims', '50',
                        '--part', '0.5,1'], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    data = json.loads((tmp_path / 'v' / 'validation.json').read_text())
    assert data['part'] == [0.5, 1.0] and data['samples'] == 350
    assert len(data['north']['acf_measured']) == data['max_lag'] + 1
    assert (tmp_path / 'v' / 'validation.png').read_bytes()[:4] == b'\x89PNG'
    r = subprocess.run([sys.executable, '-m', 'gps_error_ros.cli', 'validate', 'DS3',
                        str(csv), '--out', str(tmp_path / 'v')],
                       capture_output=True, text=True)
    assert r.returncode == 2 and 'no published fit' in r.stderr


def test_the_map_zooms_to_the_size_of_the_errors():
    from gps_error_ros.reports.validation_figure import map_window_of
    trace, _ = synthetic_trace(400, seed=5)               # a static receiver
    res = validate(TRUE, trace, sims=20)
    win, _ = map_window_of(res, 180)
    assert win.stop - win.start == 181                    # all near: the full window
    # a walk at 1.4 m/s with these ~1 m errors: the window holds the samples
    # within 10 SDs of the middle one, not 180 s of road
    from gps_error_ros.model.geodesy import offset
    walk = trace.__class__(trace.name, trace.t, *offset(trace.lat, trace.lon,
                                                        1.4 * trace.t, 0.0 * trace.t),
                           *offset(trace.truth_lat, trace.truth_lon, 1.4 * trace.t,
                                   0.0 * trace.t))
    res = validate(TRUE, walk, sims=20)
    win, _ = map_window_of(res, 180)
    radius = 10 * res.measured.std(axis=0).max()
    assert win.stop - win.start <= 2 * radius / 1.4 + 2


def test_the_map_legend_draws_every_marker_at_one_size():
    """The truth's large cross, scaled up with the dots, covered the legend and the plot."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from gps_error_ros.reports.validation_figure import _map_panel, LEGEND_MARKER_PT
    trace, _ = synthetic_trace(300, seed=6)               # a static receiver: the cross
    res = validate(TRUE, trace, sims=20)
    fig, ax = plt.subplots()
    try:
        _map_panel(ax, res, 180)
        sizes = [h.get_markersize() for h in ax.get_legend().legend_handles]
    finally:
        plt.close(fig)
    assert sizes == [LEGEND_MARKER_PT] * 3


def test_the_share_percentile_is_what_the_models_own_traces_give():
    # traces of the true model: the percentile of their share inside is
    # about uniform, so few fall under 5; a wrong model's trace does
    low = {'acf': 0, 'quantiles': 0}
    for seed in range(40):
        trace, _ = synthetic_trace(300, seed=100 + seed)
        s = validate(TRUE, trace, sims=100, seed=seed).to_dict()
        for k in low:
            low[k] += s['east'][f'{k}_share_percentile'] < 5
    assert low['acf'] <= 6 and low['quantiles'] <= 6, low      # about 2 expected
    bad = validate(WRONG, synthetic_trace(1500, seed=31)[0], sims=200).to_dict()
    assert bad['north']['acf_share_percentile'] < 5


def test_the_four_shares_together_reject_the_models_own_traces_at_their_level():
    # each share percentile alone rejects a model's own trace 5 % of the time,
    # so the smallest of four does more often; judged against the smallest
    # of each simulated trace's own, the joint percentile rejects at about 5 %
    worst, joint = 0, 0
    for seed in range(60):
        s = validate(TRUE, synthetic_trace(300, seed=200 + seed)[0], sims=100,
                     seed=seed).to_dict()
        worst += min(s[ax][f'{k}_share_percentile'] for ax in ('north', 'east')
                     for k in ('acf', 'quantiles')) < 5
        joint += s['shares_joint_percentile'] < 5
    assert joint <= 8, joint                     # about 3 expected
    assert worst > joint, (worst, joint)
    bad = validate(WRONG, synthetic_trace(1500, seed=31)[0], sims=200).to_dict()
    assert bad['shares_joint_percentile'] < 5


def test_recordings_judged_one_by_one_are_judged_together_by_occasion():
    from gps_error_ros.fit.validation import family_verdict
    # the occasion of two recordings counts once, at the smaller of their percentiles
    got = family_verdict([40.0, 3.0, 60.0, 20.0], [0, 1, 1, 2])
    assert got['occasions'] == 3 and got['smallest_percentile'] == pytest.approx(3.0)
    assert got['family_probability'] == pytest.approx(1.0 - 0.97 ** 3) and not got['unlike']
    assert family_verdict([1.0], [0])['unlike']


def test_validate_each_writes_every_recording_and_the_family(tmp_path):
    paths = []
    for seed in (3, 4):
        trace, _ = synthetic_trace(400, seed=seed)
        paths.append(tmp_path / f'r{seed}.csv')
        write_csv(paths[-1], trace)
    out = tmp_path / 'v'
    r = subprocess.run([sys.executable, '-m', 'gps_error_ros.cli', 'validate', 'DS1',
                        *map(str, paths), '--out', str(out), '--sims', '30', '--each'],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    family = json.loads((out / 'family.json').read_text())
    pcts = [rec['shares_joint_percentile'] for rec in family['recordings']]
    assert [rec['name'] for rec in family['recordings']] == ['r3.csv', 'r4.csv']
    assert family['occasions'] == len({rec['occasion'] for rec in family['recordings']})
    low = min(pcts) / 100.0
    assert family['family_probability'] == pytest.approx(1.0 - (1.0 - low) ** family['occasions'])
    for i, name in enumerate(('r3', 'r4')):
        one = json.loads((out / f'0{i}-{name}' / 'validation.json').read_text())
        assert one['samples'] == 400 and one['shares_joint_percentile'] == pcts[i]
        assert (out / f'0{i}-{name}' / 'validation.png').read_bytes()[:4] == b'\x89PNG'
        assert f'  {name}.csv: ACF inside' in r.stdout
    assert 'as a family:' in r.stdout and '(Sidak)' in r.stdout

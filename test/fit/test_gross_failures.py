"""Gross failures: the rule, its false positives, and the walks of data/."""

import subprocess
import sys

import numpy as np
import pytest
from scipy import signal

from gps_error_ros.fit.calibration import calibrate
from gps_error_ros.fit.gross_failures import (failure_mask, find_gross_failures,
                                              robust_centre_scale, without_rows)
from gps_error_ros.model.ar_model import ARErrorModel
from gps_error_ros.model.geodesy import difference, offset
from gps_error_ros.traces.trace_io import read_trace_csv, Trace
from measured import WALKS


def _white_trace(n, seed, sd=10.0):
    rng = np.random.default_rng(seed)
    err = rng.normal(0.0, sd, (n, 2))
    lat, lon = offset(51.76, -1.25, err[:, 0], err[:, 1])
    ones = np.ones(n)
    return Trace('white', np.arange(n, dtype=float), lat, lon, 51.76 * ones, -1.25 * ones), err


def test_planted_failures_are_found_and_nothing_else():
    trace, err = _white_trace(600, 1)
    bad = np.array([50, 51, 300, 599])
    lat, lon = trace.lat.copy(), trace.lon.copy()
    lat[bad], lon[bad] = offset(51.76, -1.25, np.array([900.0, -2500.0, 24000.0, 400.0]),
                                np.array([300.0, 100.0, -50.0, 700.0]))
    planted = Trace('planted', trace.t, lat, lon, trace.truth_lat, trace.truth_lon)
    found = find_gross_failures(planted)
    assert np.flatnonzero(found.mask).tolist() == bad.tolist()
    assert found.size_m.max() == pytest.approx(np.hypot(24000.0, 50.0), rel=1e-6)
    assert found.t.tolist() == [50.0, 51.0, 300.0, 599.0]
    summary = found.to_dict()
    assert summary['count'] == 4 and summary['fixes'] == 600
    assert 'robust distance > 5' in summary['rule']
    assert found.describe().startswith('planted: 4 gross failure(s) of 600 fixes')


def test_a_persistent_excursion_is_not_a_failure():
    """Fixes far from the median, each beside the last: the process, not failures."""
    rng = np.random.default_rng(3)
    x = signal.lfilter([1.0], [1.0, -0.9], rng.normal(0.0, 0.3, (2, 1000)), axis=-1)
    x[:, 400:460] += 12.0 * np.std(x) * np.sin(np.linspace(0.0, np.pi, 60))
    assert not failure_mask(x[0], x[1]).any()
    x[:, 700] += 40.0 * np.std(x)       # one isolated jump among them is
    assert np.flatnonzero(failure_mask(x[0], x[1])).tolist() == [700]


@pytest.mark.parametrize('phi', [0.0, 0.9, 0.995])
def test_false_positives_on_clean_ar_traces(phi):
    """The docstring's figure: clean Gaussian AR(1) traces are (almost) never flagged."""
    rng = np.random.default_rng(int(phi * 1000) + 7)
    flagged = 0
    for _ in range(100):
        z = rng.standard_normal((2, 2600))
        x = signal.lfilter([1.0], [1.0, -phi], z, axis=-1)[:, 2000:]
        x *= 10.0 * np.sqrt(1 - phi ** 2)           # 10 m SD: the robust tests decide
        flagged += int(failure_mask(x[0], x[1]).sum())
    assert flagged <= 1            # of 60 000 fixes; the rule's nominal rate is 3.7e-6


def test_a_steady_phone_s_few_metre_moves_are_not_failures():
    """A phone that repeats one position: a robust spread near 0, moves of 5 m."""
    north = np.zeros(200)
    north[[4, 5, 6, 33, 51]] = 5.0
    east = np.full(200, 0.1)
    assert not failure_mask(north, east).any()
    north[120] = 400.0                          # a failed solution still is one
    assert np.flatnonzero(failure_mask(north, east)).tolist() == [120]


def test_scale_falls_back_when_the_mad_is_zero():
    x = np.r_[np.zeros(60), np.ones(20), [5.0]]
    m, s = robust_centre_scale(x)
    assert m == 0.0 and s == pytest.approx(1.2533 * 25.0 / 81)
    assert robust_centre_scale(np.ones(10))[1] == 0.0
    assert not failure_mask(np.ones(10), np.ones(10)).any()
    far = np.ones(10)
    far[4] = 90.0                    # a constant axis does not hide a failure on it
    assert np.flatnonzero(failure_mask(far, np.ones(10))).tolist() == [4]


def test_without_rows_keeps_the_rest():
    trace, _ = _white_trace(10, 2)
    trace.extra['accuracy'] = np.arange(10.0)
    out = without_rows(trace, np.arange(10) % 3 == 0)
    assert out.t.tolist() == [1.0, 2.0, 4.0, 5.0, 7.0, 8.0]
    assert out.extra['accuracy'].tolist() == out.t.tolist()
    assert without_rows(trace, np.zeros(10, bool)) is trace


@pytest.mark.parametrize('path', WALKS, ids=[p.stem for p in WALKS])
def test_walk_fit_is_not_set_by_its_failures(path):
    """The issue's check: fitted per-axis SD within 30 % of the robust SD (beyond 200 m out)."""
    trace = read_trace_csv(path)
    north, east = difference(trace.lat, trace.lon, trace.truth_lat, trace.truth_lon)
    near = np.hypot(north, east) <= 200.0
    result = calibrate(trace)
    assert result.reported.fitted, result.reported.reason
    sd = ARErrorModel(result.north.params, result.east.params).stationary_sd
    for i, axis in enumerate((north, east)):
        robust = robust_centre_scale(axis[near])[1]
        assert abs(sd[i] / robust - 1.0) < 0.30, (path.name, i, sd[i], robust)
    far = np.flatnonzero(~near)
    assert set(far) <= set(np.flatnonzero(result.failures[0].mask))
    fit = result.profile_dict('w')['fit']
    assert fit['gross_failures']['count'] == result.failures[0].count


def test_calibrate_command_on_walks_prints_no_warning(tmp_path):
    """Every visible walk and all of them together: exit 0, no warning on the terminal."""
    folder = tmp_path / 'walks'
    folder.mkdir()
    for p in WALKS:
        (folder / p.name).symlink_to(p)
    runs = [[str(p)] for p in WALKS] + [[str(folder)]]
    for inputs in runs:
        out = tmp_path / 'p.yaml'
        proc = subprocess.run([sys.executable, '-m', 'gps_error_ros.cli', 'calibrate',
                               *inputs, '-o', str(out)], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        assert proc.stderr == '', proc.stderr
        assert 'Warning' not in proc.stdout
        assert 'gross failure' in proc.stdout
    assert f'{len(WALKS)} recordings' in proc.stdout


def test_a_profile_of_the_walks_gives_each_receiver_its_own_failure_rate(tmp_path):
    """
    With --population, calibrate fits how receivers differ in failing; validate uses it.

    One rate for every walk puts the busiest walk's count outside its 95 %
    range; a rate per agent, fitted from the walks' counts, holds it.
    """
    import yaml
    folder = tmp_path / 'walks'
    folder.mkdir()
    for p in WALKS:
        (folder / p.name).symlink_to(p)
    prof = tmp_path / 'p.yaml'
    cli = [sys.executable, '-m', 'gps_error_ros.cli']
    proc = subprocess.run([*cli, 'calibrate', '--population', str(folder), '-o', str(prof)],
                          capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stderr == '', proc.stderr
    raw = yaml.safe_load(prof.read_text())
    assert raw['gross_failures']['rate_sd_log'] > 0.5
    one_rate = tmp_path / 'one.yaml'
    raw['gross_failures'].pop('rate_sd_log')
    one_rate.write_text(yaml.safe_dump(raw))
    busiest = max(WALKS, key=lambda p: find_gross_failures(read_trace_csv(p)).count)
    lines = {}
    for name, path in (('own', prof), ('one', one_rate)):
        proc = subprocess.run([*cli, 'validate', str(path), str(busiest), '--sims', '20',
                               '--out', str(tmp_path / name)], capture_output=True, text=True)
        assert proc.returncode == 0 and proc.stderr == '', proc.stderr
        lines[name] = next(ln for ln in proc.stdout.splitlines()
                           if 'gross failures: measured' in ln)
    assert "each recording's own" in lines['own'] and lines['own'].endswith('inside')
    assert lines['one'].endswith('OUTSIDE'), lines['one']

"""
``gps_error diagnose``: blind runs on synthetic walks, and its parts.

The quick subset: one seed (the same for every scenario, not chosen by the
outcome) per single-effect scenario of :mod:`gps_error_ros.sim.synthetic`.
The long run over a hundred seeds per effect-free scenario, twenty per
effect, and the pairs of effects, is ``make diagnose-long``.
"""

import json
import math
import subprocess
import sys

import matplotlib.pyplot as plt
import pytest

from gps_error_ros.diagnose import ALPHA, diagnose, DiagnosisError
from gps_error_ros.diagnose.common import round_levels
from gps_error_ros.diagnose.family import holm
from gps_error_ros.model.profiles import load_profile
from gps_error_ros.sim.synthetic import PAIRS, SCENARIOS, STREAM, synthetic_trace
from gps_error_ros.traces.trace_io import read_trace_csv, write_trace_csv

SEED = 1


@pytest.mark.parametrize('scenario', [s for s in SCENARIOS if s not in PAIRS])
def test_blind_attribution(scenario):
    expected, unexplained = SCENARIOS[scenario]
    s = diagnose(synthetic_trace(scenario, SEED, 3600), sims=30).findings
    found = s.effect_names
    assert sorted(found) == sorted(expected), (found, s.tests)
    assert bool(s.unexplained) == unexplained, s.unexplained
    before = s.error_before.heldout_nll_per_sample
    after = s.error_after.heldout_nll_per_sample
    if expected:
        assert after < before, (before, after)
        assert s.improvement.heldout_nll_per_sample == pytest.approx(before - after, abs=1e-5)
    else:
        assert after == before
        assert s.improvement.ci95 == (0.0, 0.0)
    # each round's Holm at its share of the diagnosis's level, the two summing to it
    assert s.alpha == ALPHA
    assert sum(round_levels(ALPHA)) == pytest.approx(ALPHA)
    for tests, level in zip((s.tests, s.extended.retest or {}), round_levels(ALPHA)):
        given = {k: t.holm_adjusted_p for k, t in tests.items() if t.given}
        reject, adjusted = holm({k: t.p_value for k, t in tests.items()}, level, given)
        for k, t in tests.items():
            assert t.holm_adjusted_p == pytest.approx(adjusted[k], rel=1e-5, abs=1e-9)
            assert t.rejected == reject[k], (k, t, level)


def test_every_scenario_has_its_own_fixed_stream():
    """Adding a scenario must not change the walks of the others (seeded tests rely on it)."""
    assert set(STREAM) == set(SCENARIOS)
    assert len(set(STREAM.values())) == len(STREAM)
    a, b = synthetic_trace('none', 4, 120), synthetic_trace('none', 4, 120)
    assert (a.lat == b.lat).all() and (a.t == b.t).all()
    assert not (a.lat == synthetic_trace('ar5', 4, 120).lat).all()


def test_too_short_trace_is_refused_with_the_reason():
    tr = synthetic_trace('none', 0, 200)
    with pytest.raises(DiagnosisError) as exc:
        diagnose(tr, sims=5)
    assert 'training' in str(exc.value) and 'need at least' in str(exc.value)


def test_cli_writes_json_report_and_a_profile_the_node_can_load(tmp_path):
    walk = write_trace_csv(synthetic_trace('street_ellipse', 3, 2400),
                           tmp_path / 'walk.csv')
    assert len(read_trace_csv(walk)) > 2000
    out = subprocess.run(
        [sys.executable, '-m', 'gps_error_ros.cli', 'diagnose', str(walk),
         '--json', str(tmp_path / 'd.json'), '--report', str(tmp_path / 'r'),
         '--profile-out', str(tmp_path / 'ext.yaml'), '--sims', '20'],
        capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    d = json.loads((tmp_path / 'd.json').read_text())
    for key in ('input', 'samples', 'train_samples', 'test_samples', 'base',
                'effects', 'unexplained', 'error_before', 'error_after'):
        assert key in d
    assert d['samples'] == d['train_samples'] + d['test_samples']
    assert d['base']['order']['north'] >= 1
    for side in ('error_before', 'error_after'):
        m = d[side]
        assert math.isfinite(m['heldout_nll_per_sample'])
        assert {'acf_distance', 'ne_correlation', 'horizontal_quantiles_m'} <= set(m)
    png = tmp_path / 'r' / 'diagnosis.png'
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    img = plt.imread(png)
    assert img.shape[:2] == (990, 1320)                  # 12 x 9 in at 110 dpi
    h, w = img.shape[0] // 2, img.shape[1] // 2
    for panel in (img[:h, :w], img[:h, w:], img[h:, :w], img[h:, w:]):
        # each of the four panels has drawn content, not a blank page
        assert (panel[..., :3].std(axis=-1) > 0.1).mean() > 0.005
    prof = load_profile(str(tmp_path / 'ext.yaml'))
    # the profile has the effects the cross-validation kept, a subset of those found
    assert prof.effects.names == tuple(d['selection']['kept'])
    assert set(prof.effects.names) <= {e['name'] for e in d['effects']}
    assert 'cross_axis_coupling' in prof.effects.names
    cov = prof.model().stationary_cov
    assert cov[0, 1] > 0                       # ellipse along the 29 deg avenues
    bad = subprocess.run(
        [sys.executable, '-m', 'gps_error_ros.cli', 'diagnose',
         str(tmp_path / 'missing.csv')], capture_output=True, text=True)
    assert bad.returncode == 2 and 'missing.csv' in bad.stderr

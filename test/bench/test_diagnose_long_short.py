"""The long blind run, short: its report gives each share with its interval, and pools them."""

import json
import sys
from pathlib import Path

import pytest
from scipy import stats

from gps_error_ros.fit.fidelity import binomial_interval

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / 'bench'))
import diagnose_long  # noqa: E402


def test_clopper_pearson_interval():
    """At the ends the interval has a closed form; inside it is the beta quantiles'."""
    assert binomial_interval(0, 20) == pytest.approx((0.0, 1 - 0.025 ** (1 / 20)))
    assert binomial_interval(20, 20) == pytest.approx((0.025 ** (1 / 20), 1.0))
    lo, hi = binomial_interval(18, 20)
    assert stats.binom.sf(17, 20, lo) == pytest.approx(0.025)
    assert stats.binom.cdf(18, 20, hi) == pytest.approx(0.025)
    with pytest.raises(ValueError, match='n > 0'):
        binomial_interval(0, 0)


def test_short_long_run_reports_intervals_and_pooled_shares(tmp_path, capsys):
    out = tmp_path / 'run.json'
    diagnose_long.main(['--seeds', '2', '--effect-seeds', '2', '--duration', '900',
                        '--first-seed', '5000', '--workers', '1', '--json', str(out),
                        '--scenarios', 'none', 'street_ellipse', 'drifting_wave'])
    text = capsys.readouterr().out
    assert 'street_ellipse' in text and '95 % CI' in text and 'pooled' in text
    rec = json.loads(out.read_text())
    assert sorted({r['seed'] for r in rec['runs']}) == [5000, 5001]
    s, pooled = rec['summary'], rec['pooled']
    assert pooled['seeds'] == 4
    assert pooled['right'] == s['street_ellipse']['right'] + s['drifting_wave']['right']
    # drifting_wave expects nothing fitted: only street_ellipse's walks count for the NLL
    assert pooled['after_better_seeds'] == 2
    assert pooled['after_better'] == s['street_ellipse']['after_better']

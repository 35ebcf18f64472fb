"""The soak, short: 100 agents for 5 simulated minutes (make soak runs 24 h)."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / 'bench'))
import soak  # noqa: E402

pytestmark = pytest.mark.integration


def test_short_soak():
    r = soak.run(agents=100, sim_s=300, sample_s=60, window_s=120, rss_growth_mb=20.0)
    assert r['missing'] == 0 and r['unexpected'] == 0 and r['duplicates'] == 0, (
        r['missing'], r['missing_steps'], r['unexpected'], r['duplicates'],
        r['speed_x_real_time'], r['node_summary'])
    assert r['fixes_received'] == 100 * 300
    assert r['rss_growth_mb'] <= 20.0, r['rss_mb_samples']
    assert all(c['ok'] for c in r['stats'].values()), r['stats']
    assert r['passed']
